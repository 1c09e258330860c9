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
    long long deadline_ns;  /* an input's deadline (0: none); the loop's watch reads it */
    long long expired;      /* an input's: the slot's seq when the watch found it past its
                             * deadline (0: not past it; a later write is a new value) */
} PortObject;

/* ---- Plans ------------------------------------------------------------------------ */

/* Prefetching: after the loop's sleep, a component's working set (its object, its
 * attribute values, its ports and their slots) comes back from far caches, one line
 * after another, as each update touches it. While update s runs, the loop asks the CPU
 * for the lines of update s + RTCF_PREFETCH_DISTANCE, so that their misses overlap
 * with the work instead of following it (docs/performance.md#the-hot-path-in-c: 200
 * trivial components at 500 Hz, 86-90 ns per component without, 77-82 with). The
 * addresses are taken when a plan is compiled and are only ever hints: a prefetch of
 * memory that has since moved or been freed does nothing. 0 turns it off. */
#ifndef RTCF_PREFETCH_DISTANCE
#define RTCF_PREFETCH_DISTANCE 3
#endif
#define RTCF_WARM 8 /* lines per step: the object, its values, 6 ports or slots */
#if defined(__GNUC__) || defined(__clang__)
#define rtcf_prefetch(p) __builtin_prefetch((p), 1, 3)
#else
#define rtcf_prefetch(p) ((void)(p))
#endif

/* one update of a plan: its timing column, and what to call. A bound method is kept
 * as its function and its self, called as fn(self): one indirection less per call */
typedef struct {
    Py_ssize_t column;
    PyObject *fn;
    PyObject *self; /* NULL: fn() */
    int nwarm;
    const void *warm[RTCF_WARM]; /* what fn(self) will touch: prefetched, never read */
} CalcStep;

static inline void
prefetch_step(const CalcStep *st)
{
    for (int q = 0; q < st->nwarm; q++)
        rtcf_prefetch(st->warm[q]);
}

typedef struct {
    Py_ssize_t nsteps, nskipped;
    CalcStep *steps;
    Py_ssize_t *skipped;
} CalcPhase;

/* an executor's plans compiled into arrays (_compiled_plans.c): where the executor
 * builds its plans, so that the loop only takes them */
typedef struct {
    PyObject_HEAD
    PyObject *plans;    /* the tuple of (steps, skipped) compiled */
    Py_ssize_t nphases; /* its length: > 0 */
    CalcPhase *phases;
    Py_ssize_t columns; /* 1 + the largest column: a timing row must be this wide */
} CompiledPlansObject;

/* plans compiled into a new CompiledPlans; NULL with an exception */
RTCF_INTERNAL PyObject *compiled_plans_new(PyObject *plans);

/* the types (each defined in its file; the module adds them) */
RTCF_INTERNAL extern PyTypeObject SlotType, LoopStateType;
RTCF_INTERNAL extern PyTypeObject PortType, OutputPortType, InputPortType;
RTCF_INTERNAL extern PyTypeObject CompiledPlansType, CalculationType;
RTCF_INTERNAL extern PyTypeObject RingGateType, HeartbeatType, DeadlineGateType;
RTCF_INTERNAL extern PyTypeObject WordTapType, HandoverType;
RTCF_INTERNAL extern PyTypeObject CommandCheckType; /* _compiled_limits.c */

/* the module's state (_compiled.c): FlowStatus's members (rtcf._core._ports hands them
 * in), and the names the calculation and the plans look up */
RTCF_INTERNAL extern PyObject *flow_status[4];
RTCF_INTERNAL extern PyObject *str_plans, *str_compiled_plans, *str_inputs, *str_outputs;

/* obj's buffer as writable int64 words into view; 0, or -1 with an exception */
RTCF_INTERNAL int get_words(PyObject *obj, Py_buffer *view, const char *what);

/* the tp_dealloc of a GC type that no class may subclass: untrack, its own tp_clear,
 * free. Runs when the object dies, never per iteration */
RTCF_INTERNAL void rtcf_gc_dealloc(PyObject *self);

/* What opens every type object of the module: its qualified name, the struct of its
 * objects and its doc (PyVarObject_HEAD_INIT brings its own comma) */
#define RTCF_TYPE(qualname, Object, doc) \
    PyVarObject_HEAD_INIT(NULL, 0)       \
    .tp_name = qualname,                 \
    .tp_doc = doc,                       \
    .tp_basicsize = sizeof(Object)

/* The three slots of a GC type that no class may subclass, given Prefix_traverse and
 * Prefix_clear in its file: written together because rtcf_gc_dealloc calls the type's
 * own tp_clear, which a type with this dealloc must therefore have */
#define RTCF_GC_SLOTS(Prefix)                      \
    .tp_dealloc = rtcf_gc_dealloc,                 \
    .tp_traverse = (traverseproc)Prefix##_traverse, \
    .tp_clear = (inquiry)Prefix##_clear

#endif /* RTCF_COMPILED_H */
