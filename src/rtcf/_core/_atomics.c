/* Memory fences for rtcf's lock-free channels between processes (rtcf._core._rings).
 *
 * A ring's producer writes a record and then its head counter; the consumer reads
 * the head and then the record. On x86-64 the CPU keeps those stores and loads in
 * program order (total store order), so the pure-Python channels need nothing more.
 * Weakly ordered CPUs (ARMv8 as on a Raspberry Pi, POWER, RISC-V) may make the head
 * visible before the record, or satisfy the record's load before the head's: the
 * channels call these fences between the steps there. Python cannot issue a fence
 * itself, hence this module.
 *
 * Each function is an opaque call for the C compiler, and the fence inside is a
 * compiler barrier too: no load or store of the caller moves across it. What the
 * CPU is told (GCC and Clang, -O2):
 *   release_fence  ARMv8: dmb ish    x86-64: nothing (TSO)   RISC-V: fence rw,w
 *   acquire_fence  ARMv8: dmb ishld  x86-64: nothing (TSO)   RISC-V: fence r,rw
 */

#define PY_SSIZE_T_CLEAN
#include <Python.h>

static PyObject *
release_fence(PyObject *module, PyObject *Py_UNUSED(ignored))
{
    /* Loads and stores before it complete before any store after it. */
    __atomic_thread_fence(__ATOMIC_RELEASE);
    Py_RETURN_NONE;
}

static PyObject *
acquire_fence(PyObject *module, PyObject *Py_UNUSED(ignored))
{
    /* Loads before it complete before any load or store after it. */
    __atomic_thread_fence(__ATOMIC_ACQUIRE);
    Py_RETURN_NONE;
}

static PyMethodDef atomics_methods[] = {
    {"release_fence", release_fence, METH_NOARGS,
     "release_fence() -> None\n--\n\n"
     "Order every load and store before it before every store after it."},
    {"acquire_fence", acquire_fence, METH_NOARGS,
     "acquire_fence() -> None\n--\n\n"
     "Order every load before it before every load and store after it."},
    {NULL, NULL, 0, NULL},
};

static PyModuleDef_Slot atomics_slots[] = {
#if PY_VERSION_HEX >= 0x030C0000
    {Py_mod_multiple_interpreters, Py_MOD_PER_INTERPRETER_GIL_SUPPORTED},
#endif
#if PY_VERSION_HEX >= 0x030D0000
    {Py_mod_gil, Py_MOD_GIL_NOT_USED},
#endif
    {0, NULL},
};

static struct PyModuleDef atomics_module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "rtcf._core._atomics",
    .m_doc = "Memory fences for rtcf's lock-free channels on weakly ordered CPUs.",
    .m_size = 0,
    .m_methods = atomics_methods,
    .m_slots = atomics_slots,
};

PyMODINIT_FUNC
PyInit__atomics(void)
{
    return PyModuleDef_Init(&atomics_module);
}
