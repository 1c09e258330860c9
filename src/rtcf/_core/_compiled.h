/* rtcf._core._compiled's internal header: what its files share (as CPython's
 * Modules/_io/_iomodule.h does for _io). Not installed, not for other modules.
 *
 * The objects that several files read (a slot, the loop state, a port), the type
 * objects that one file defines and others check against or the module adds, the
 * module's interned names, and the helpers of the per-iteration path that more than
 * one file calls: static inline here, so that splitting the files costs no call. */

#ifndef RTCF_COMPILED_H
#define RTCF_COMPILED_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <errno.h>
#include <stdint.h>
#include <limits.h>
#include <sched.h>
#include <string.h>
#include <time.h>

/* what one file defines for the others: not exported from the module's .so (and, in
 * a position-independent build, read without the global offset table) */
#if defined(__GNUC__) || defined(__clang__)
#define RTCF_INTERNAL __attribute__((visibility("hidden")))
#else
#define RTCF_INTERNAL
#endif

#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#define RTCF_HAVE_CYCLES 1
/* the CPU's time-stamp counter: 10 ns to read here, against 25 ns for clock_gettime
 * through the vDSO, once per component per iteration. Only where the kernel's own
 * clocksource is the TSC (invariant and synchronised across CPUs), which the caller
 * checks (rtcf._core._hotpath.component_clock) */
static inline unsigned long long
cycles(void)
{
    return __rdtsc();
}
#else
#define RTCF_HAVE_CYCLES 0
static inline unsigned long long
cycles(void)
{
    return 0;
}
#endif

static inline long long
monotonic_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* ---- Slot ------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    PyObject *value;
    long long seq;       /* number of writes; 0 means never written */
    long long iteration; /* the loop iteration of the last write (-1: none, or outside) */
} SlotObject;

/* ---- LoopState -------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD
    double frequency;
    long long period_ns;
    long long iteration; /* -1 before the first iteration */
    long long time_ns;   /* scheduled start of the current iteration, since the loop started */
    long long stamp_ns;  /* the same instant in ROS time */
    char running;
} LoopStateObject;

/* ---- Port, OutputPort, InputPort -------------------------------------------------- */

/* rtcf's ports themselves (rtcf._core._ports re-exports them): C types, not Python
 * subclasses of one, because CPython's fast path for a call of a C method checks that
 * the instance's type is exactly the method's (a subclass takes the slow path). */
typedef struct {
    PyObject_HEAD
    SlotObject *slot;       /* never NULL */
    LoopStateObject *state; /* NULL: a port outside a loop (writes record iteration -1) */
    PyObject *tap;          /* an output's: NULL, or called with every written value */
    long long seen;         /* an input's: the slot's seq at its last read */
    PyObject *component;    /* full name of the owning component */
    PyObject *name;         /* the name given in add_input/add_output */
    PyObject *type;         /* the value type */
    PyObject *topic;        /* resolved topic name, set when the runner wires the graph */
    PyObject *producer;     /* an input's: the OutputPort writing its topic, or NULL */
} PortObject;

/* the types (each defined in its file; the module adds them) */
RTCF_INTERNAL extern PyTypeObject SlotType, LoopStateType;
RTCF_INTERNAL extern PyTypeObject PortType, OutputPortType, InputPortType;
RTCF_INTERNAL extern PyTypeObject CalculationType, RingGateType, HeartbeatType;
RTCF_INTERNAL extern PyTypeObject WordTapType, HandoverType;

/* the module's state (_compiled.c): FlowStatus's members (rtcf._core._ports hands them
 * in), and the names the calculation looks up */
RTCF_INTERNAL extern PyObject *flow_status[3];
RTCF_INTERNAL extern PyObject *str_plans, *str_inputs, *str_outputs;

/* obj's buffer as writable int64 words into view; 0, or -1 with an exception */
RTCF_INTERNAL int get_words(PyObject *obj, Py_buffer *view, const char *what);

#endif /* RTCF_COMPILED_H */
