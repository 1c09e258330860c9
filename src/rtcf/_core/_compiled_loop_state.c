/* rtcf._core._compiled: LoopState, what the loop tells components (iteration, time,
 * stamp, rate); the ports, the calculation, the taps and the handovers read it. */

#include "_compiled.h"

/* ---- LoopState -------------------------------------------------------------------- */

static int
LoopState_init(LoopStateObject *s, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"frequency", NULL};
    double frequency = 1.0;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "|d:LoopState", kwlist, &frequency))
        return -1;
    if (!(frequency > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "LoopState: the frequency must be positive");
        return -1;
    }
    s->frequency = frequency;
    /* round(1e9 / frequency), as Python rounds: half to even */
    s->period_ns = (long long)nearbyint(1e9 / frequency);
    s->iteration = -1;
    s->time_ns = 0;
    s->stamp_ns = 0;
    s->running = 0;
    return 0;
}

static PyMemberDef LoopState_members[] = {
    {"frequency", T_DOUBLE, offsetof(LoopStateObject, frequency), 0, "The loop's rate [Hz]."},
    {"period_ns", T_LONGLONG, offsetof(LoopStateObject, period_ns), 0, "Its period [ns]."},
    {"iteration", T_LONGLONG, offsetof(LoopStateObject, iteration), 0,
     "The current iteration (-1 before the first)."},
    {"time_ns", T_LONGLONG, offsetof(LoopStateObject, time_ns), 0,
     "Scheduled start of the current iteration, since the loop started [ns]."},
    {"stamp_ns", T_LONGLONG, offsetof(LoopStateObject, stamp_ns), 0,
     "The same instant in ROS time [ns since the epoch]."},
    {"running", T_BOOL, offsetof(LoopStateObject, running), 0, "Whether the loop runs."},
    {NULL},
};

PyTypeObject LoopStateType = {
    RTCF_TYPE("rtcf._core._compiled.LoopState", LoopStateObject,
              "What the loop tells components about the current iteration."),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)LoopState_init,
    .tp_members = LoopState_members,
};
