/* The loop's hot path, compiled: rtcf._core._compiled
 * (docs/performance.md#the-hot-path-in-c).
 *
 * What runs once per component per iteration, written against CPython's C API:
 *
 *   Slot          a topic's latest value, how many writes, and the iteration of the last
 *   LoopState     what the loop tells components (iteration, time, stamp, rate)
 *   Port, OutputPort, InputPort
 *                 rtcf's ports (rtcf._core._ports re-exports them): a slot, the loop's
 *                 state, what a reader last saw, an output's tap; write, read, status
 *   Calculation   the timed part of one iteration: wake-up time, the loop state, the
 *                 feeders, each component's update called by vectorcall with its time
 *                 (from the TSC where the kernel's clocksource is the TSC, else from
 *                 CLOCK_MONOTONIC) stored into the timing row, the running word
 *   CompiledPlans an executor's plans as arrays (what each update calls, what it will
 *                 touch), built where the executor builds its plans: the loop takes them
 *   WordTap       a recorded float, int or bool output: the write pushes its record
 *   Handover      a value crossing lanes: a send, a receive, a LET lane's output
 *   RingGate, HeartbeatWatch, DeadlineGate
 *                 the loop's feeders in every iteration: a few word reads each in the
 *                 common case (no control record waits; the supervisor's heartbeat moved;
 *                 no watched input came back or passed its deadline)
 *   CommandCheck  a hardware command input's check in one call: finite, within its
 *                 bounds and its rate limit, clamped into the guard's own array
 *
 * One module built from one file per concept and one internal header, _compiled.h,
 * as CPython builds Modules/_io/: _compiled_slot.c, _compiled_loop_state.c,
 * _compiled_ports.c, _compiled_plans.c, _compiled_calculation.c, _compiled_word_tap.c,
 * _compiled_handover.c, _compiled_feeders.c (RingGate, HeartbeatWatch, DeadlineGate) and
 * _compiled_limits.c (CommandCheck). This file
 * holds the module itself: its state, its two functions and its initialisation.
 *
 * rtcf._core._interpreted is the same in Python, line for line: the path used where
 * this module cannot be built, or with RTCF_PURE_PYTHON=1. Both must keep exactly
 * the same semantics (tests/unit/test_hotpath.py runs them side by side).
 *
 * Nothing here allocates in the steady state except what Python itself does for a
 * call's result and the int that ``iterate`` returns.
 */

#include "_compiled.h"

/* FlowStatus's members (NO_DATA, OLD_DATA, NEW_DATA, EXPIRED): rtcf._core._ports hands
 * them in */
PyObject *flow_status[4] = {NULL, NULL, NULL, NULL};
PyObject *str_plans = NULL, *str_compiled_plans = NULL;
PyObject *str_inputs = NULL, *str_outputs = NULL;

/* the words a calculation, a feeder, a tap or a handover is given (at its init) */
int
get_words(PyObject *obj, Py_buffer *view, const char *what)
{
    if (PyObject_GetBuffer(obj, view, PyBUF_WRITABLE | PyBUF_FORMAT | PyBUF_C_CONTIGUOUS) < 0)
        return -1;
    if (view->itemsize != 8 || view->format == NULL ||
        (strcmp(view->format, "q") != 0 && strcmp(view->format, "l") != 0 &&
         strcmp(view->format, "<q") != 0 && strcmp(view->format, "=q") != 0)) {
        PyErr_Format(PyExc_TypeError, "Calculation: %s must be int64 words", what);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

void
rtcf_gc_dealloc(PyObject *self)
{
    PyTypeObject *type = Py_TYPE(self);
    PyObject_GC_UnTrack(self);
    (void)type->tp_clear(self);
    type->tp_free(self);
}

/* ---- the module ------------------------------------------------------------------- */

static PyObject *
set_flow_status(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError,
                        "set_flow_status(no_data, old_data, new_data, expired)");
        return NULL;
    }
    for (int k = 0; k < 4; k++)
        Py_XSETREF(flow_status[k], Py_NewRef(args[k]));
    Py_RETURN_NONE;
}

/* ns_per_cycle(): nanoseconds per tick of the cycle counter, measured against
 * CLOCK_MONOTONIC over 2 ms (one relative error of about 1e-5); 0.0 where there is none */
static PyObject *
ns_per_cycle(PyObject *module, PyObject *Py_UNUSED(ignored))
{
    if (!RTCF_HAVE_CYCLES)
        return PyFloat_FromDouble(0.0);
    long long t0, t1;
    unsigned long long c0, c1;
    struct timespec pause = {0, 2000000};
    Py_BEGIN_ALLOW_THREADS
    t0 = monotonic_ns();
    c0 = cycles();
    nanosleep(&pause, NULL);
    t1 = monotonic_ns();
    c1 = cycles();
    Py_END_ALLOW_THREADS
    if (c1 <= c0 || t1 <= t0)
        return PyFloat_FromDouble(0.0);
    return PyFloat_FromDouble((double)(t1 - t0) / (double)(c1 - c0));
}

static PyMethodDef module_methods[] = {
    {"ns_per_cycle", (PyCFunction)ns_per_cycle, METH_NOARGS,
     "ns_per_cycle()\n--\n\nNanoseconds per tick of the CPU's cycle counter, measured "
     "over 2 ms; 0.0 where rtcf does not read one."},
    {"set_flow_status", (PyCFunction)(void (*)(void))set_flow_status, METH_FASTCALL,
     "set_flow_status(no_data, old_data, new_data, expired)\n--\n\nWhat a port's status returns."},
    {NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "rtcf._core._compiled",
    "The loop's hot path in C (rtcf._core._interpreted is the same in Python).", -1,
    module_methods,
};

PyMODINIT_FUNC
PyInit__compiled(void)
{
    if (PyType_Ready(&SlotType) < 0 || PyType_Ready(&LoopStateType) < 0 ||
        PyType_Ready(&PortType) < 0 || PyType_Ready(&OutputPortType) < 0 ||
        PyType_Ready(&InputPortType) < 0 || PyType_Ready(&CompiledPlansType) < 0 ||
        PyType_Ready(&CalculationType) < 0 ||
        PyType_Ready(&RingGateType) < 0 || PyType_Ready(&HeartbeatType) < 0 ||
        PyType_Ready(&DeadlineGateType) < 0 ||
        PyType_Ready(&WordTapType) < 0 || PyType_Ready(&HandoverType) < 0 ||
        PyType_Ready(&CommandCheckType) < 0)
        return NULL;
    str_plans = PyUnicode_InternFromString("plans");
    str_compiled_plans = PyUnicode_InternFromString("compiled_plans");
    str_inputs = PyUnicode_InternFromString("_rtcf_inputs");
    str_outputs = PyUnicode_InternFromString("_rtcf_outputs");
    if (str_plans == NULL || str_compiled_plans == NULL || str_inputs == NULL || str_outputs == NULL)
        return NULL;
    /* direction: a class attribute of each port type */
    PyObject *out = PyUnicode_InternFromString("output"), *in = PyUnicode_InternFromString("input");
    if (out == NULL || in == NULL ||
        PyDict_SetItemString(OutputPortType.tp_dict, "direction", out) < 0 ||
        PyDict_SetItemString(InputPortType.tp_dict, "direction", in) < 0)
        return NULL;
    Py_DECREF(out);
    Py_DECREF(in);
    PyType_Modified(&OutputPortType);
    PyType_Modified(&InputPortType);
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddObjectRef(m, "Slot", (PyObject *)&SlotType) < 0 ||
        PyModule_AddObjectRef(m, "LoopState", (PyObject *)&LoopStateType) < 0 ||
        PyModule_AddObjectRef(m, "Port", (PyObject *)&PortType) < 0 ||
        PyModule_AddObjectRef(m, "OutputPort", (PyObject *)&OutputPortType) < 0 ||
        PyModule_AddObjectRef(m, "InputPort", (PyObject *)&InputPortType) < 0 ||
        PyModule_AddObjectRef(m, "CompiledPlans", (PyObject *)&CompiledPlansType) < 0 ||
        PyModule_AddObjectRef(m, "Calculation", (PyObject *)&CalculationType) < 0 ||
        PyModule_AddObjectRef(m, "RingGate", (PyObject *)&RingGateType) < 0 ||
        PyModule_AddObjectRef(m, "HeartbeatWatch", (PyObject *)&HeartbeatType) < 0 ||
        PyModule_AddObjectRef(m, "DeadlineGate", (PyObject *)&DeadlineGateType) < 0 ||
        PyModule_AddObjectRef(m, "WordTap", (PyObject *)&WordTapType) < 0 ||
        PyModule_AddObjectRef(m, "Handover", (PyObject *)&HandoverType) < 0 ||
        PyModule_AddObjectRef(m, "CommandCheck", (PyObject *)&CommandCheckType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
