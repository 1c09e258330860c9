/* rtcf._core._compiled: Calculation, the timed part of one iteration: wake-up time, the
 * loop state, the feeders, each component's update called by vectorcall with its time
 * (from the TSC or CLOCK_MONOTONIC) stored into the timing row, the running word, and
 * the prefetching of the next updates' working sets (the plans' arrays:
 * _compiled_plans.c). */

#include "_compiled.h"

/* ---- Calculation ------------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD
    PyObject *executor;      /* its ``plans`` (a tuple of (steps, skipped)) each iteration */
    LoopStateObject *state;
    PyObject *feeders;       /* a tuple of callables */
    PyObject *now;           /* NULL: CLOCK_MONOTONIC read directly */
    PyObject *sleep_until;   /* NULL: clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) */
    Py_buffer running, words, scratch;
    int held;                /* the three buffers are held */
    long long origin, ros_offset;
    Py_ssize_t width;        /* a timing row's words */
    Py_ssize_t nwords;       /* words in the ring */
    Py_ssize_t c_iteration, c_scheduled, c_jitter, c_calc, c_phase;
    double ns_per_cycle;     /* > 0: components timed by the cycle counter */
    /* executor.plans, while it is this object, and its arrays (calc_take): held by
     * compiled, copied here so that an iteration reads them as its own */
    PyObject *taken_plans;
    PyObject *compiled;      /* a CompiledPlans */
    Py_ssize_t nphases;
    CalcPhase *phases;
} CalculationObject;

/* the clock's time; -1 with an exception set on failure */
static inline long long
calc_now(CalculationObject *c)
{
    if (c->now == NULL)
        return monotonic_ns();
    PyObject *res = PyObject_Vectorcall(c->now, NULL, 0, NULL);
    if (res == NULL)
        return -1;
    long long t = PyLong_AsLongLong(res);
    Py_DECREF(res);
    if (t == -1 && PyErr_Occurred())
        return -1;
    return t;
}

/* sleep until the absolute deadline; 0, or -1 with an exception (a signal's handler
 * raised). A signal that interrupts the sleep ends it: the loop looks at its stop word. */
static int
calc_sleep(CalculationObject *c, long long deadline)
{
    if (c->sleep_until != NULL) {
        PyObject *arg = PyLong_FromLongLong(deadline);
        if (arg == NULL)
            return -1;
        PyObject *res = PyObject_CallOneArg(c->sleep_until, arg);
        Py_DECREF(arg);
        if (res == NULL)
            return -1;
        Py_DECREF(res);
        return 0;
    }
    struct timespec ts;
    ts.tv_sec = (time_t)(deadline / 1000000000LL);
    ts.tv_nsec = (long)(deadline % 1000000000LL);
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
    Py_END_ALLOW_THREADS
    if (rc == EINTR)
        return PyErr_CheckSignals();
    if (rc != 0) {
        errno = rc;
        PyErr_SetFromErrno(PyExc_OSError);
        return -1;
    }
    return 0;
}

static void
calc_release(CalculationObject *c)
{
    if (c->held) {
        PyBuffer_Release(&c->running);
        PyBuffer_Release(&c->words);
        PyBuffer_Release(&c->scratch);
        c->held = 0;
    }
}

static void
calc_forget_plans(CalculationObject *c)
{
    c->nphases = 0;
    c->phases = NULL;
    Py_CLEAR(c->compiled);
    Py_CLEAR(c->taken_plans);
}

/* executor.plans as arrays: the executor's compiled_plans, compiled where it built
 * them (nothing to allocate here), or, for plans given otherwise, compiled now */
static int
calc_take(CalculationObject *c, PyObject *plans)
{
    PyObject *ready = PyObject_GetAttr(c->executor, str_compiled_plans);
    if (ready == NULL) {
        if (!PyErr_ExceptionMatches(PyExc_AttributeError))
            return -1;
        PyErr_Clear();
    } else if (!Py_IS_TYPE(ready, &CompiledPlansType) ||
               ((CompiledPlansObject *)ready)->plans != plans) {
        Py_CLEAR(ready);
    }
    if (ready == NULL && (ready = compiled_plans_new(plans)) == NULL)
        return -1;
    CompiledPlansObject *cp = (CompiledPlansObject *)ready;
    if (cp->columns > c->width) {
        Py_DECREF(ready);
        PyErr_SetString(PyExc_IndexError, "Calculation: a plan's column outside the row");
        return -1;
    }
    Py_XSETREF(c->compiled, ready);
    Py_XSETREF(c->taken_plans, Py_NewRef(plans));
    c->nphases = cp->nphases;
    c->phases = cp->phases;
    return 0;
}

static int
Calculation_init(CalculationObject *c, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"executor", "state", "feeders", "now", "sleep_until",
                             "native_now", "native_sleep", "running", "words", "scratch",
                             "origin", "ros_offset", "width", "columns", "ns_per_cycle",
                             NULL};
    PyObject *executor, *state, *feeders, *now, *sleep_until, *running, *words, *scratch;
    int native_now, native_sleep;
    long long origin, ros_offset;
    Py_ssize_t width;
    Py_ssize_t cols[5];
    double ns_per_cycle = 0.0;
    if (!PyArg_ParseTupleAndKeywords(
            args, kwds, "OO!O!OOppOOOLLn(nnnnn)|d:Calculation", kwlist, &executor,
            &LoopStateType, &state, &PyTuple_Type, &feeders, &now, &sleep_until, &native_now,
            &native_sleep, &running, &words,
            &scratch, &origin, &ros_offset, &width, &cols[0], &cols[1], &cols[2], &cols[3],
            &cols[4], &ns_per_cycle))
        return -1;
    calc_release(c);
    calc_forget_plans(c);
    if (get_words(running, &c->running, "the running word") < 0)
        return -1;
    if (get_words(words, &c->words, "the timing ring") < 0) {
        PyBuffer_Release(&c->running);
        return -1;
    }
    if (get_words(scratch, &c->scratch, "the scratch row") < 0) {
        PyBuffer_Release(&c->running);
        PyBuffer_Release(&c->words);
        return -1;
    }
    c->held = 1;
    for (int k = 0; k < 5; k++) {
        if (cols[k] < 0 || cols[k] >= width) {
            calc_release(c);
            PyErr_SetString(PyExc_ValueError, "Calculation: a column outside the row");
            return -1;
        }
    }
    if (c->running.len < 8 || c->scratch.len < 8 * width || width <= 0) {
        calc_release(c);
        PyErr_SetString(PyExc_ValueError, "Calculation: the running word or scratch too short");
        return -1;
    }
    Py_XSETREF(c->executor, Py_NewRef(executor));
    Py_XSETREF(c->state, (LoopStateObject *)Py_NewRef(state));
    Py_XSETREF(c->feeders, Py_NewRef(feeders));
    Py_CLEAR(c->now);
    Py_CLEAR(c->sleep_until);
    /* another clock: its own now and sleep, called each time */
    if (!native_now)
        c->now = Py_NewRef(now);
    if (!native_sleep)
        c->sleep_until = Py_NewRef(sleep_until);
    c->origin = origin;
    c->ros_offset = ros_offset;
    c->width = width;
    c->nwords = c->words.len / 8;
    c->c_iteration = cols[0];
    c->c_scheduled = cols[1];
    c->c_jitter = cols[2];
    c->c_calc = cols[3];
    c->c_phase = cols[4];
    /* only on CLOCK_MONOTONIC itself (another clock, a simulated one, times as it says) */
    c->ns_per_cycle = (RTCF_HAVE_CYCLES && native_now && ns_per_cycle > 0.0) ? ns_per_cycle : 0.0;
    return 0;
}

static int
Calculation_traverse(CalculationObject *c, visitproc visit, void *arg)
{
    Py_VISIT(c->executor);
    Py_VISIT(c->state);
    Py_VISIT(c->feeders);
    Py_VISIT(c->now);
    Py_VISIT(c->sleep_until);
    Py_VISIT(c->taken_plans);
    Py_VISIT(c->compiled);
    return 0;
}

static int
Calculation_clear(CalculationObject *c)
{
    calc_release(c);
    calc_forget_plans(c);
    Py_CLEAR(c->executor);
    Py_CLEAR(c->state);
    Py_CLEAR(c->feeders);
    Py_CLEAR(c->now);
    Py_CLEAR(c->sleep_until);
    return 0;
}

/* iterate(i, deadline, b): sleep until deadline, then the timed part of iteration i;
 * its timing row is words[b:] (b < 0: the scratch row, the ring was full). Returns
 * the time it ended. An update that raises leaves its column in the running word. */
static PyObject *
Calculation_iterate(CalculationObject *c, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "iterate(i, deadline, b)");
        return NULL;
    }
    if (!c->held) {
        PyErr_SetString(PyExc_RuntimeError, "Calculation: released");
        return NULL;
    }
    long long i = PyLong_AsLongLong(args[0]);
    if (i == -1 && PyErr_Occurred())
        return NULL;
    long long deadline = PyLong_AsLongLong(args[1]);
    if (deadline == -1 && PyErr_Occurred())
        return NULL;
    Py_ssize_t b = PyLong_AsSsize_t(args[2]);
    if (b == -1 && PyErr_Occurred())
        return NULL;
    long long *row;
    if (b >= 0) {
        if (b + c->width > c->nwords) {
            PyErr_SetString(PyExc_IndexError, "Calculation: a row past the ring's end");
            return NULL;
        }
        row = (long long *)c->words.buf + b;
    } else {
        row = (long long *)c->scratch.buf;
    }
    long long *running = (long long *)c->running.buf;

    if (calc_sleep(c, deadline) < 0)
        return NULL;
    long long t0 = calc_now(c);
    if (t0 == -1 && PyErr_Occurred())
        return NULL;
    LoopStateObject *state = c->state;
    state->iteration = i;
    state->time_ns = deadline - c->origin;
    state->stamp_ns = deadline + c->ros_offset;
    long long t = t0;
    Py_ssize_t nf = PyTuple_GET_SIZE(c->feeders);
    if (nf) { /* in the iteration's time, not in its first component's */
        for (Py_ssize_t f = 0; f < nf; f++) {
            PyObject *res = PyObject_Vectorcall(PyTuple_GET_ITEM(c->feeders, f), NULL, 0, NULL);
            if (res == NULL)
                return NULL;
            Py_DECREF(res);
        }
        t = calc_now(c);
        if (t == -1 && PyErr_Occurred())
            return NULL;
    }
    /* read after the feeders (a swap applies now); new plans are taken compiled */
    PyObject *plans = PyObject_GetAttr(c->executor, str_plans);
    if (plans == NULL)
        return NULL;
    if (plans != c->taken_plans && calc_take(c, plans) < 0) {
        Py_DECREF(plans);
        return NULL;
    }
    Py_DECREF(plans); /* c->taken_plans holds it */
    long long phase = i % c->nphases;
    if (phase < 0)
        phase += c->nphases;
    CalcPhase *ph = &c->phases[phase];
    double per_cycle = c->ns_per_cycle;
    unsigned long long cyc = per_cycle > 0.0 ? cycles() : 0;
    Py_ssize_t n = ph->nsteps;
    const Py_ssize_t ahead = RTCF_PREFETCH_DISTANCE;
    for (Py_ssize_t s = 0; s < n && s < ahead; s++)
        prefetch_step(&ph->steps[s]);
    for (Py_ssize_t s = 0; s < n; s++) {
        CalcStep *st = &ph->steps[s];
        Py_ssize_t k = st->column;
        if (ahead > 0 && s + ahead < n)
            prefetch_step(&ph->steps[s + ahead]);
        running[0] = k;
        PyObject *res;
        if (st->self != NULL) {
            PyObject *argv[2] = {NULL, st->self};
            res = PyObject_Vectorcall(st->fn, argv + 1, 1 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        } else {
            res = PyObject_Vectorcall(st->fn, NULL, 0, NULL);
        }
        if (res == NULL)
            return NULL; /* the running word names the column */
        Py_DECREF(res);
        if (per_cycle > 0.0) {
            unsigned long long cyc1 = cycles();
            /* (a counter that went back, on another CPU: 0, never a wrapped delta) */
            row[k] = cyc1 > cyc ? (long long)((double)(cyc1 - cyc) * per_cycle + 0.5) : 0;
            cyc = cyc1;
            continue;
        }
        long long t1 = c->now == NULL ? monotonic_ns() : calc_now(c);
        if (t1 == -1 && PyErr_Occurred())
            return NULL;
        row[k] = t1 - t;
        t = t1;
    }
    if (per_cycle > 0.0 && n > 0)
        t = monotonic_ns(); /* the iteration's end, on the clock its deadlines are on */
    running[0] = -1;
    for (Py_ssize_t s = 0; s < ph->nskipped; s++)
        row[ph->skipped[s]] = -1; /* SKIPPED */
    row[c->c_iteration] = i;
    row[c->c_scheduled] = deadline;
    row[c->c_jitter] = t0 - deadline;
    row[c->c_calc] = t - t0;
    row[c->c_phase] = phase;
    return PyLong_FromLongLong(t);
}

static PyObject *
Calculation_release(CalculationObject *c, PyObject *Py_UNUSED(ignored))
{
    calc_release(c);
    Py_RETURN_NONE;
}

static PyMethodDef Calculation_methods[] = {
    {"iterate", (PyCFunction)(void (*)(void))Calculation_iterate, METH_FASTCALL,
     "iterate(i, deadline, b)\n--\n\nThe timed part of iteration i; returns when it ended."},
    {"release", (PyCFunction)Calculation_release, METH_NOARGS,
     "release()\n--\n\nLet go of the running word, the ring and the scratch row."},
    {NULL},
};

PyTypeObject CalculationType = {
    RTCF_TYPE("rtcf._core._compiled.Calculation", CalculationObject,
              "The timed part of the loop's iterations (see rtcf._core._executor)."),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Calculation_init,
    RTCF_GC_SLOTS(Calculation),
    .tp_methods = Calculation_methods,
};
