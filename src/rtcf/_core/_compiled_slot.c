/* rtcf._core._compiled: Slot, a topic's latest value, how many writes, and the
 * iteration of the last (the ports share one per topic). */

#include "_compiled.h"

/* ---- Slot ------------------------------------------------------------------------- */

static PyObject *
Slot_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    if (PyTuple_GET_SIZE(args) != 0 || (kwds != NULL && PyDict_GET_SIZE(kwds) != 0)) {
        PyErr_SetString(PyExc_TypeError, "Slot() takes no arguments");
        return NULL;
    }
    SlotObject *s = (SlotObject *)type->tp_alloc(type, 0);
    if (s == NULL)
        return NULL;
    s->value = Py_NewRef(Py_None);
    s->seq = 0;
    s->iteration = -1;
    return (PyObject *)s;
}

static int
Slot_traverse(SlotObject *s, visitproc visit, void *arg)
{
    Py_VISIT(s->value);
    return 0;
}

static int
Slot_clear(SlotObject *s)
{
    Py_CLEAR(s->value);
    return 0;
}

static PyObject *
Slot_get_value(SlotObject *s, void *closure)
{
    return Py_NewRef(s->value != NULL ? s->value : Py_None);
}

static int
Slot_set_value(SlotObject *s, PyObject *value, void *closure)
{
    if (value == NULL) {
        PyErr_SetString(PyExc_AttributeError, "a slot's value cannot be deleted");
        return -1;
    }
    Py_XSETREF(s->value, Py_NewRef(value));
    return 0;
}

static PyGetSetDef Slot_getset[] = {
    {"value", (getter)Slot_get_value, (setter)Slot_set_value,
     "The latest value (None before the first write).", NULL},
    {NULL},
};

static PyMemberDef Slot_members[] = {
    {"seq", T_LONGLONG, offsetof(SlotObject, seq), 0, "Number of writes; 0: never written."},
    {"iteration", T_LONGLONG, offsetof(SlotObject, iteration), 0,
     "The loop iteration of the last write (-1: none, or outside a loop)."},
    {NULL},
};

PyTypeObject SlotType = {
    RTCF_TYPE("rtcf._core._compiled.Slot", SlotObject,
              "The latest value on one topic and how many times it was written."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = Slot_new,
    RTCF_GC_SLOTS(Slot),
    .tp_getset = Slot_getset,
    .tp_members = Slot_members,
};
