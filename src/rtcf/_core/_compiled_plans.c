/* rtcf._core._compiled: CompiledPlans, an executor's plans as the calculation runs them:
 * arrays of what each update calls and what it will touch (prefetched), built where the
 * executor builds its plans (rtcf._core._executor.Executor.set_active), so that the
 * loop's first iteration after a change (a lifecycle transition, a fault's fallback)
 * only takes them and allocates nothing. */

#include "_compiled.h"

/* ---- Plans ------------------------------------------------------------------------ */

/* where an instance's attribute values live (CPython's layout of each version: what
 * LOAD_ATTR reads for ``self.port``); NULL where unknown */
static const void *
attribute_values(PyObject *self)
{
    PyTypeObject *t = Py_TYPE(self);
#ifdef Py_TPFLAGS_MANAGED_DICT
    if (t->tp_flags & Py_TPFLAGS_MANAGED_DICT) {
#if PY_VERSION_HEX < 0x030C0000
        return ((void **)self)[-4]; /* 3.11: the values pointer, before the dict's */
#elif PY_VERSION_HEX < 0x030D0000
        uintptr_t dorv = ((uintptr_t *)self)[-3]; /* 3.12: values tagged by -1, or a dict */
        return (const void *)((dorv & 1) ? dorv + 1 : dorv);
#else
        if (t->tp_flags & Py_TPFLAGS_INLINE_VALUES) /* 3.13: values follow the object */
            return (const char *)self + t->tp_basicsize;
        return ((void **)self)[-3]; /* else its dict */
#endif
    }
#endif
    if (t->tp_dictoffset > 0) /* 3.10, or a class with __dict__ in its layout */
        return *(void **)((char *)self + t->tp_dictoffset);
    return NULL;
}

/* a component's ports (its _rtcf_inputs and _rtcf_outputs tables) and their slots */
static void
warm_ports(CalcStep *st, PyObject *table_name)
{
    /* generic: no __getattr__ of the component's class runs for a hint */
    PyObject *table = PyObject_GenericGetAttr(st->self, table_name);
    if (table == NULL) { /* not a component: a lane's handover, a test's callable */
        PyErr_Clear();
        return;
    }
    if (PyDict_CheckExact(table)) {
        Py_ssize_t pos = 0;
        PyObject *name, *port;
        while (st->nwarm + 2 <= RTCF_WARM && PyDict_Next(table, &pos, &name, &port)) {
            if (!PyObject_TypeCheck(port, &PortType))
                continue;
            st->warm[st->nwarm++] = port;
            st->warm[st->nwarm++] = ((PortObject *)port)->slot;
        }
    }
    Py_DECREF(table);
}

static void
warm_step(CalcStep *st)
{
    st->nwarm = 0;
    if (st->self == NULL)
        return;
    st->warm[st->nwarm++] = st->self;
    const void *values = attribute_values(st->self);
    if (values != NULL)
        st->warm[st->nwarm++] = values;
    warm_ports(st, str_inputs);
    warm_ports(st, str_outputs);
}


static void
plans_forget(CompiledPlansObject *cp)
{
    if (cp->phases != NULL) {
        for (Py_ssize_t h = 0; h < cp->nphases; h++) {
            CalcPhase *ph = &cp->phases[h];
            for (Py_ssize_t s = 0; s < ph->nsteps; s++) {
                Py_XDECREF(ph->steps[s].fn);
                Py_XDECREF(ph->steps[s].self);
            }
            PyMem_Free(ph->steps);
            PyMem_Free(ph->skipped);
        }
        PyMem_Free(cp->phases);
        cp->phases = NULL;
    }
    cp->nphases = 0;
    cp->columns = 0;
    Py_CLEAR(cp->plans);
}

static int
bad_plans(void)
{
    PyErr_SetString(PyExc_TypeError,
                    "Calculation: executor.plans must be a tuple of (steps, skipped) tuples");
    return -1;
}

/* a column of a plan: >= 0, and counted into the row's width */
static int
plans_column(CompiledPlansObject *cp, PyObject *item, Py_ssize_t *col)
{
    *col = PyLong_AsSsize_t(item);
    if (*col < 0) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_IndexError, "Calculation: a plan's column outside the row");
        return -1;
    }
    if (*col >= cp->columns)
        cp->columns = *col + 1;
    return 0;
}

/* plans (a tuple of (steps, skipped): steps a tuple of (column, callable), skipped a
 * tuple of columns) into arrays, checked once: when the executor builds them (a load,
 * a lifecycle transition), not in the loop */
static int
plans_compile(CompiledPlansObject *cp, PyObject *plans)
{
    plans_forget(cp);
    if (!PyTuple_Check(plans) || PyTuple_GET_SIZE(plans) == 0)
        return bad_plans();
    Py_ssize_t h = PyTuple_GET_SIZE(plans);
    cp->phases = PyMem_Calloc((size_t)h, sizeof(CalcPhase));
    if (cp->phases == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    cp->nphases = h;
    for (Py_ssize_t p = 0; p < h; p++) {
        PyObject *plan = PyTuple_GET_ITEM(plans, p);
        if (!PyTuple_Check(plan) || PyTuple_GET_SIZE(plan) != 2)
            goto bad;
        PyObject *steps = PyTuple_GET_ITEM(plan, 0), *skipped = PyTuple_GET_ITEM(plan, 1);
        if (!PyTuple_Check(steps) || !PyTuple_Check(skipped))
            goto bad;
        CalcPhase *ph = &cp->phases[p];
        Py_ssize_t n = PyTuple_GET_SIZE(steps), ns = PyTuple_GET_SIZE(skipped);
        ph->steps = PyMem_Calloc((size_t)(n ? n : 1), sizeof(CalcStep));
        ph->skipped = PyMem_Calloc((size_t)(ns ? ns : 1), sizeof(Py_ssize_t));
        if (ph->steps == NULL || ph->skipped == NULL) {
            PyErr_NoMemory();
            goto fail;
        }
        for (Py_ssize_t k = 0; k < n; k++) {
            PyObject *step = PyTuple_GET_ITEM(steps, k);
            if (!PyTuple_Check(step) || PyTuple_GET_SIZE(step) != 2)
                goto bad;
            Py_ssize_t col;
            if (plans_column(cp, PyTuple_GET_ITEM(step, 0), &col) < 0)
                goto fail;
            PyObject *fn = PyTuple_GET_ITEM(step, 1);
            CalcStep *st = &ph->steps[ph->nsteps++];
            st->column = col;
            if (PyMethod_Check(fn)) {
                st->fn = Py_NewRef(PyMethod_GET_FUNCTION(fn));
                st->self = Py_NewRef(PyMethod_GET_SELF(fn));
                warm_step(st);
            } else {
                st->fn = Py_NewRef(fn);
                st->self = NULL;
            }
        }
        for (Py_ssize_t k = 0; k < ns; k++) {
            Py_ssize_t col;
            if (plans_column(cp, PyTuple_GET_ITEM(skipped, k), &col) < 0)
                goto fail;
            ph->skipped[ph->nskipped++] = col;
        }
    }
    cp->plans = Py_NewRef(plans);
    return 0;
bad:
    bad_plans();
fail:
    plans_forget(cp);
    return -1;
}

PyObject *
compiled_plans_new(PyObject *plans)
{
    CompiledPlansObject *cp = PyObject_GC_New(CompiledPlansObject, &CompiledPlansType);
    if (cp == NULL)
        return NULL;
    cp->plans = NULL;
    cp->nphases = 0;
    cp->phases = NULL;
    cp->columns = 0;
    PyObject_GC_Track(cp);
    if (plans_compile(cp, plans) < 0) {
        Py_DECREF(cp);
        return NULL;
    }
    return (PyObject *)cp;
}

static PyObject *
CompiledPlans_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PyObject *plans;
    static char *kwlist[] = {"plans", NULL};
    if (type != &CompiledPlansType) {
        PyErr_SetString(PyExc_TypeError, "CompiledPlans cannot be subclassed");
        return NULL;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "O:CompiledPlans", kwlist, &plans))
        return NULL;
    return compiled_plans_new(plans);
}

static int
CompiledPlans_traverse(CompiledPlansObject *cp, visitproc visit, void *arg)
{
    Py_VISIT(cp->plans);
    for (Py_ssize_t h = 0; cp->phases != NULL && h < cp->nphases; h++) {
        for (Py_ssize_t s = 0; s < cp->phases[h].nsteps; s++) {
            Py_VISIT(cp->phases[h].steps[s].fn);
            Py_VISIT(cp->phases[h].steps[s].self);
        }
    }
    return 0;
}

static int
CompiledPlans_clear(CompiledPlansObject *cp)
{
    plans_forget(cp);
    return 0;
}

static PyObject *
CompiledPlans_get_plans(CompiledPlansObject *cp, void *Py_UNUSED(closure))
{
    return Py_NewRef(cp->plans != NULL ? cp->plans : Py_None);
}

static PyGetSetDef CompiledPlans_getset[] = {
    {"plans", (getter)CompiledPlans_get_plans, NULL, "The plans compiled.", NULL},
    {NULL},
};

static PyMemberDef CompiledPlans_members[] = {
    {"columns", T_PYSSIZET, offsetof(CompiledPlansObject, columns), READONLY,
     "1 + the largest column: how wide a timing row must be."},
    {NULL},
};

PyTypeObject CompiledPlansType = {
    RTCF_TYPE("rtcf._core._compiled.CompiledPlans", CompiledPlansObject,
              "CompiledPlans(plans): an executor's plans as the calculation runs them."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = CompiledPlans_new,
    RTCF_GC_SLOTS(CompiledPlans),
    .tp_getset = CompiledPlans_getset,
    .tp_members = CompiledPlans_members,
};
