/* rtcf._core._compiled: rtcf's ports, Port, OutputPort and InputPort (rtcf._core._ports
 * re-exports them): a slot, the loop's state, what a reader last saw, an output's tap;
 * write, read, status. */

#include "_compiled.h"

/* ---- Port, OutputPort, InputPort -------------------------------------------------- */

static PyObject *
Port_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PortObject *p = (PortObject *)type->tp_alloc(type, 0);
    if (p == NULL)
        return NULL;
    p->slot = (SlotObject *)PyObject_CallNoArgs((PyObject *)&SlotType);
    p->component = PyUnicode_FromString("");
    p->name = PyUnicode_FromString("");
    p->topic = PyUnicode_FromString("");
    p->type = Py_NewRef((PyObject *)&PyBaseObject_Type);
    if (p->slot == NULL || p->component == NULL || p->name == NULL || p->topic == NULL) {
        Py_DECREF(p);
        return NULL;
    }
    return (PyObject *)p;
}

static int
Port_init(PortObject *p, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"component", "name", "type_", "state", NULL};
    static char *kwlist3[] = {"component", "name", "type_", NULL};
    PyObject *component, *name, *type, *state = Py_None;
    const char *format = PyObject_TypeCheck((PyObject *)p, &OutputPortType) ? "UUO|O:OutputPort"
                         : PyObject_TypeCheck((PyObject *)p, &InputPortType) ? "UUO:InputPort"
                                                                             : "UUO:Port";
    int output = format[3] == '|';
    if (!PyArg_ParseTupleAndKeywords(args, kwds, format, output ? kwlist : kwlist3, &component,
                                     &name, &type, &state))
        return -1;
    if (state != Py_None && !PyObject_TypeCheck(state, &LoopStateType)) {
        PyErr_SetString(PyExc_TypeError, "a port's state must be a LoopState or None");
        return -1;
    }
    Py_XSETREF(p->component, Py_NewRef(component));
    Py_XSETREF(p->name, Py_NewRef(name));
    Py_XSETREF(p->type, Py_NewRef(type));
    Py_CLEAR(p->state);
    if (state != Py_None)
        p->state = (LoopStateObject *)Py_NewRef(state);
    return 0;
}

static int
Port_traverse(PortObject *p, visitproc visit, void *arg)
{
    Py_VISIT(p->slot);
    Py_VISIT(p->state);
    Py_VISIT(p->tap);
    Py_VISIT(p->component);
    Py_VISIT(p->name);
    Py_VISIT(p->type);
    Py_VISIT(p->topic);
    Py_VISIT(p->producer);
    return 0;
}

static int
Port_clear(PortObject *p)
{
    Py_CLEAR(p->slot);
    Py_CLEAR(p->state);
    Py_CLEAR(p->tap);
    Py_CLEAR(p->component);
    Py_CLEAR(p->name);
    Py_CLEAR(p->type);
    Py_CLEAR(p->topic);
    Py_CLEAR(p->producer);
    return 0;
}

static void
Port_dealloc(PortObject *p)
{
    PyObject_GC_UnTrack(p);
    Port_clear(p);
    Py_TYPE(p)->tp_free((PyObject *)p);
}

static PyObject *
OutputPort_write(PortObject *p, PyObject *value)
{
    SlotObject *s = p->slot;
    Py_SETREF(s->value, Py_NewRef(value));
    s->seq++;
    s->iteration = p->state != NULL ? p->state->iteration : -1;
    if (p->tap == NULL) /* mapped to the middleware or recorded: the tap too, after */
        Py_RETURN_NONE;
    PyObject *arg[1] = {value};
    PyObject *res = PyObject_Vectorcall(p->tap, arg, 1, NULL);
    if (res == NULL)
        return NULL;
    Py_DECREF(res);
    Py_RETURN_NONE;
}

static PyObject *
InputPort_read(PortObject *p, PyObject *Py_UNUSED(ignored))
{
    SlotObject *s = p->slot;
    p->seen = s->seq;
    return Py_NewRef(s->value != NULL ? s->value : Py_None);
}

static PyObject *
InputPort_status(PortObject *p, void *closure)
{
    long long seq = p->slot->seq;
    /* EXPIRED only while the value the watch found too old is still the latest: a value
     * written since (earlier in this iteration) is new data at once */
    int k = seq == 0 ? 0 : (seq == p->expired ? 3 : (seq != p->seen ? 2 : 1));
    if (flow_status[k] == NULL)
        return PyLong_FromLong(k);
    return Py_NewRef(flow_status[k]);
}

static PyObject *
InputPort_deadline(PortObject *p, void *closure)
{
    if (p->deadline_ns <= 0)
        Py_RETURN_NONE;
    return PyFloat_FromDouble((double)p->deadline_ns / 1e9);
}

static PyObject *
InputPort_has_new_data(PortObject *p, void *closure)
{
    return PyBool_FromLong(p->slot->seq != p->seen);
}

static PyObject *
InputPort_iteration(PortObject *p, void *closure)
{
    return PyLong_FromLongLong(p->slot->iteration);
}

static PyObject *
InputPort_connected(PortObject *p, void *closure)
{
    return PyBool_FromLong(p->producer != NULL);
}

/* _connect(producer): share producer's slot, or get a fresh private one (no producer;
 * one that stays unconnected keeps what a bridge may have fed it) */
static PyObject *
InputPort_connect(PortObject *p, PyObject *producer)
{
    if (producer != Py_None && !PyObject_TypeCheck(producer, &OutputPortType)) {
        PyErr_SetString(PyExc_TypeError, "an input's producer must be an OutputPort or None");
        return NULL;
    }
    SlotObject *slot;
    if (producer != Py_None)
        slot = (SlotObject *)Py_NewRef(((PortObject *)producer)->slot);
    else if (p->producer == NULL)
        slot = (SlotObject *)Py_NewRef(p->slot);
    else {
        slot = (SlotObject *)PyObject_CallNoArgs((PyObject *)&SlotType);
        if (slot == NULL)
            return NULL;
    }
    if (slot != p->slot) {
        Py_SETREF(p->slot, slot);
        p->seen = 0;
    } else {
        Py_DECREF(slot);
    }
    Py_CLEAR(p->producer);
    if (producer != Py_None)
        p->producer = Py_NewRef(producer);
    Py_RETURN_NONE;
}

static PyObject *
Port_qualified_name(PortObject *p, void *closure)
{
    return PyUnicode_FromFormat("%S.%S", p->component, p->name);
}

static PyObject *
Port_get_slot(PortObject *p, void *closure)
{
    return Py_NewRef((PyObject *)p->slot);
}

static int
Port_set_slot(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || !PyObject_TypeCheck(value, &SlotType)) {
        PyErr_SetString(PyExc_TypeError, "a port's _slot must be a Slot");
        return -1;
    }
    Py_XSETREF(p->slot, (SlotObject *)Py_NewRef(value));
    return 0;
}

static PyObject *
Port_get_state(PortObject *p, void *closure)
{
    return Py_NewRef(p->state != NULL ? (PyObject *)p->state : Py_None);
}

static int
Port_set_state(PortObject *p, PyObject *value, void *closure)
{
    if (value == NULL || value == Py_None) {
        Py_CLEAR(p->state);
        return 0;
    }
    if (!PyObject_TypeCheck(value, &LoopStateType)) {
        PyErr_SetString(PyExc_TypeError, "a port's _state must be a LoopState or None");
        return -1;
    }
    Py_XSETREF(p->state, (LoopStateObject *)Py_NewRef(value));
    return 0;
}

static PyObject *
Port_get_tap(PortObject *p, void *closure)
{
    return Py_NewRef(p->tap != NULL ? p->tap : Py_None);
}

/* a field that None (or deleting the attribute) empties */
static int
set_or_clear(PyObject **field, PyObject *value)
{
    if (value == NULL || value == Py_None)
        Py_CLEAR(*field);
    else
        Py_XSETREF(*field, Py_NewRef(value));
    return 0;
}

static int
Port_set_tap(PortObject *p, PyObject *value, void *closure)
{
    return set_or_clear(&p->tap, value);
}

static PyObject *
Port_get_producer(PortObject *p, void *closure)
{
    return Py_NewRef(p->producer != NULL ? p->producer : Py_None);
}

static int
Port_set_producer(PortObject *p, PyObject *value, void *closure)
{
    return set_or_clear(&p->producer, value);
}

static PyObject *
port_repr(PortObject *p, const char *kind, const char *arrow)
{
    PyObject *tname = PyObject_GetAttrString(p->type, "__name__");
    if (tname == NULL) {
        PyErr_Clear();
        tname = PyObject_Repr(p->type);
        if (tname == NULL)
            return NULL;
    }
    PyObject *r =
        PyUnicode_GET_LENGTH(p->topic)
            ? PyUnicode_FromFormat("<%s %S.%S %s %S [%S]>", kind, p->component, p->name, arrow,
                                   p->topic, tname)
            : PyUnicode_FromFormat("<%s %S.%S %s ? [%S]>", kind, p->component, p->name, arrow,
                                   tname);
    Py_DECREF(tname);
    return r;
}

static PyObject *
OutputPort_repr(PortObject *p)
{
    return port_repr(p, "OutputPort", "->");
}

static PyObject *
InputPort_repr(PortObject *p)
{
    return port_repr(p, "InputPort", "<-");
}

static PyMethodDef Port_methods[] = {
    {"__class_getitem__", Py_GenericAlias, METH_O | METH_CLASS, "OutputPort[float] etc."},
    {NULL},
};

static PyGetSetDef Port_getset[] = {
    {"_slot", (getter)Port_get_slot, (setter)Port_set_slot, NULL, NULL},
    {"_state", (getter)Port_get_state, (setter)Port_set_state, NULL, NULL},
    {"_tap", (getter)Port_get_tap, (setter)Port_set_tap, NULL, NULL},
    {"qualified_name", (getter)Port_qualified_name, NULL, "component.name", NULL},
    {NULL},
};

static PyMemberDef Port_members[] = {
    {"component", T_OBJECT_EX, offsetof(PortObject, component), 0,
     "Full name of the owning component."},
    {"name", T_OBJECT_EX, offsetof(PortObject, name), 0, "The name given in add_input/add_output."},
    {"type", T_OBJECT_EX, offsetof(PortObject, type), 0, "The value type."},
    {"topic", T_OBJECT_EX, offsetof(PortObject, topic), 0,
     "The resolved topic name (set when the runner wires the graph)."},
    {"_seen", T_LONGLONG, offsetof(PortObject, seen), 0, NULL},
    {"_deadline_ns", T_LONGLONG, offsetof(PortObject, deadline_ns), 0, NULL},
    {"_expired", T_LONGLONG, offsetof(PortObject, expired), 0, NULL},
    {NULL},
};

PyTypeObject PortType = {
    RTCF_TYPE("rtcf.Port", PortObject, "Common part of inputs and outputs."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_new = Port_new,
    .tp_init = (initproc)Port_init,
    .tp_dealloc = (destructor)Port_dealloc,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = Port_methods,
    .tp_getset = Port_getset,
    .tp_members = Port_members,
};

static PyMethodDef OutputPort_methods[] = {
    {"write", (PyCFunction)OutputPort_write, METH_O,
     "write(value)\n--\n\nMake value the topic's latest value."},
    {NULL},
};

PyTypeObject OutputPortType = {
    RTCF_TYPE("rtcf.OutputPort", PortObject,
              "An output port: ``write(value)`` makes ``value`` the topic's latest value."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_base = &PortType,
    .tp_repr = (reprfunc)OutputPort_repr,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = OutputPort_methods,
};

static PyMethodDef InputPort_methods[] = {
    {"read", (PyCFunction)InputPort_read, METH_NOARGS,
     "read()\n--\n\nReturn the latest value (None before the first write) and mark it as "
     "seen."},
    {"_connect", (PyCFunction)InputPort_connect, METH_O,
     "_connect(producer)\n--\n\nShare producer's slot, or get a fresh private one (None)."},
    {NULL},
};

static PyGetSetDef InputPort_getset[] = {
    {"status", (getter)InputPort_status, NULL,
     "EXPIRED if the value is older than the port's deadline, else NEW_DATA if written "
     "since this port's last read, OLD_DATA if not, or NO_DATA.", NULL},
    {"deadline", (getter)InputPort_deadline, NULL,
     "The deadline in seconds (add_input(..., deadline=) or the launch file), or None.",
     NULL},
    {"has_new_data", (getter)InputPort_has_new_data, NULL,
     "True if the value was written since this port's last read().", NULL},
    {"iteration", (getter)InputPort_iteration, NULL,
     "The loop iteration in which the value on this topic was written: with components at "
     "several rates, which iteration's value a reader sees (-1 before the first write, and "
     "for values fed from the middleware).", NULL},
    {"connected", (getter)InputPort_connected, NULL,
     "True if a producer inside the runner writes this input's topic.", NULL},
    {"producer", (getter)Port_get_producer, (setter)Port_set_producer,
     "The OutputPort writing this input's topic inside the runner, or None.", NULL},
    {NULL},
};

PyTypeObject InputPortType = {
    RTCF_TYPE("rtcf.InputPort", PortObject,
              "An input port: ``read()`` returns the latest value on its topic, or None."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC,
    .tp_base = &PortType,
    .tp_repr = (reprfunc)InputPort_repr,
    .tp_traverse = (traverseproc)Port_traverse,
    .tp_clear = (inquiry)Port_clear,
    .tp_methods = InputPort_methods,
    .tp_getset = InputPort_getset,
};
