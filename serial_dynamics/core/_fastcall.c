/* serial_dynamics.core._fastcall: a single-state entry point called without numba's
 * dispatcher.
 *
 * Why: numba's dispatcher takes ~95-110 ns for a call's first array argument and ~33-35 ns
 * for each further one (bench/bench_call_cost.py), and more for a real entry point's arrays
 * (the UR5's mass matrix: 417 ns through it, 178 past it), more than the arithmetic. An Entry calls the machine code numba compiled for the entry point's one
 * signature (core.dispatch) directly, after checking in C that every argument is of that
 * signature's types; any other call goes to the dispatcher itself, unchanged. The same
 * machine code runs either way, so the results are the same bits.
 *
 * The native function (numba's CPU calling convention, numba/core/callconv.py) is
 *     int32 f(int64 *result, excinfo **exc, <each argument flattened>)
 * where a float64 array of ndim d is (meminfo, parent, nitems, itemsize, data, shape[d],
 * strides[d]) and an int64 is itself; a status other than 0 means the function raised.
 * core.dispatch checks that numba lays the function out this way before it makes an Entry
 * (and uses the dispatcher when it does not). Every flattened value is a pointer or an
 * int64, so the call passes them as int64s: the first six in registers, the rest on the
 * stack, in order (System V AMD64 and AAPCS64 alike; the callee reads the ones it declares).
 * meminfo and parent are NULL: the entry points return a status, never an array, so
 * nothing needs to keep the caller's arrays alive past the call (numba's NRT_incref and
 * NRT_decref ignore NULL). When the function raised, the call is made again through the
 * dispatcher, which raises the exception as numba does (core/ raises only numba's static
 * exceptions, division by zero, whose excinfo is a constant: nothing to free).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stddef.h>
#include <structmember.h>
#include <stdint.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#define MAX_ARGS 16      /* arguments of an entry point */
#define MAX_WORDS 64     /* their flattened values */

typedef int64_t w;
#define W8 w, w, w, w, w, w, w, w
typedef int32_t (*native32)(w *, void **, W8, W8, W8, W8);
typedef int32_t (*native64)(w *, void **, W8, W8, W8, W8, W8, W8, W8, W8);
#define A8(i) a[i], a[i + 1], a[i + 2], a[i + 3], a[i + 4], a[i + 5], a[i + 6], a[i + 7]

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *dispatcher;     /* numba's: every call that is not of the signature */
    void *native;             /* the compiled function (numba's calling convention) */
    int nargs;
    char spec[MAX_ARGS];      /* per argument: 1, 2 or 3 (a float64 array of that ndim), i (int64) */
} Entry;

/* Appends a C-contiguous, aligned, writable, native-order float64 array of ndim nd to
 * a[*k..] as numba flattens it; 0 when the object is anything else. */
static inline int put_array(PyObject *o, int nd, w *a, int *k)
{
    if (!PyArray_CheckExact(o))
        return 0;
    PyArrayObject *x = (PyArrayObject *)o;
    if (PyArray_NDIM(x) != nd || PyArray_TYPE(x) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(x)
        || !PyArray_CHKFLAGS(x, NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED | NPY_ARRAY_WRITEABLE))
        return 0;
    int j = *k;
    a[j++] = 0;                                   /* meminfo */
    a[j++] = 0;                                   /* parent */
    a[j++] = (w)PyArray_SIZE(x);
    a[j++] = (w)sizeof(double);
    a[j++] = (w)(intptr_t)PyArray_DATA(x);
    for (int d = 0; d < nd; d++)
        a[j++] = (w)PyArray_DIM(x, d);
    for (int d = 0; d < nd; d++)
        a[j++] = (w)PyArray_STRIDE(x, d);
    *k = j;
    return 1;
}

/* Appends a Python int (not a bool) that fits an int64; 0 otherwise. */
static inline int put_int(PyObject *o, w *a, int *k)
{
    if (!PyLong_CheckExact(o))
        return 0;
    int overflow;
    long long v = PyLong_AsLongLongAndOverflow(o, &overflow);
    if (overflow || (v == -1 && PyErr_Occurred())) {
        PyErr_Clear();
        return 0;
    }
    a[(*k)++] = (w)v;
    return 1;
}

static PyObject *entry_vectorcall(PyObject *self, PyObject *const *args, size_t nargsf,
                                  PyObject *kwnames)
{
    Entry *e = (Entry *)self;
    Py_ssize_t n = PyVectorcall_NARGS(nargsf);
    w a[MAX_WORDS];          /* words past k are passed and not read */
    int k = 0;
    if (kwnames != NULL || n != e->nargs)
        goto dispatcher;
    for (int i = 0; i < n; i++) {
        char c = e->spec[i];
        if (!(c == 'i' ? put_int(args[i], a, &k) : put_array(args[i], c - '0', a, &k)))
            goto dispatcher;
    }
    w result = 0;
    void *exc = NULL;
    int32_t status;
    if (k <= 32)
        status = ((native32)e->native)(&result, &exc, A8(0), A8(8), A8(16), A8(24));
    else
        status = ((native64)e->native)(&result, &exc, A8(0), A8(8), A8(16), A8(24), A8(32),
                                       A8(40), A8(48), A8(56));
    if (status == 0)
        return PyLong_FromLongLong((long long)result);
dispatcher:          /* other arguments, or the function raised: numba's own call */
    return PyObject_Vectorcall(e->dispatcher, args, nargsf, kwnames);
}

static PyObject *entry_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    PyObject *dispatcher, *address;
    const char *spec;
    Py_ssize_t len;
    if (!PyArg_ParseTuple(args, "OOs#:Entry", &dispatcher, &address, &spec, &len))
        return NULL;
    if (len < 1 || len > MAX_ARGS) {
        PyErr_Format(PyExc_ValueError, "Entry: %zd arguments; 1 to %d are supported", len, MAX_ARGS);
        return NULL;
    }
    int words = 0;
    for (Py_ssize_t i = 0; i < len; i++) {
        char c = spec[i];
        if (c == 'i')
            words += 1;
        else if (c >= '1' && c <= '3')
            words += 5 + 2 * (c - '0');
        else {
            PyErr_Format(PyExc_ValueError, "Entry: spec %R: each argument is 1, 2, 3 (a float64 "
                         "array of that ndim) or i (an int64)", PyTuple_GET_ITEM(args, 2));
            return NULL;
        }
    }
    if (words > MAX_WORDS) {
        PyErr_Format(PyExc_ValueError, "Entry: %d flattened values; at most %d", words, MAX_WORDS);
        return NULL;
    }
    void *native = PyLong_AsVoidPtr(address);
    if (native == NULL) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "Entry: the address is 0");
        return NULL;
    }
    if (!PyCallable_Check(dispatcher)) {
        PyErr_SetString(PyExc_TypeError, "Entry: the dispatcher is not callable");
        return NULL;
    }
    Entry *e = (Entry *)type->tp_alloc(type, 0);
    if (e == NULL)
        return NULL;
    e->vectorcall = entry_vectorcall;
    Py_INCREF(dispatcher);
    e->dispatcher = dispatcher;
    e->native = native;
    e->nargs = (int)len;
    memcpy(e->spec, spec, (size_t)len);
    return (PyObject *)e;
}

static int entry_traverse(Entry *e, visitproc visit, void *arg)
{
    Py_VISIT(e->dispatcher);
    return 0;
}

static int entry_clear(Entry *e)
{
    Py_CLEAR(e->dispatcher);
    return 0;
}

static void entry_dealloc(Entry *e)
{
    PyObject_GC_UnTrack(e);
    entry_clear(e);
    Py_TYPE(e)->tp_free((PyObject *)e);
}

static PyObject *entry_repr(Entry *e)
{
    return PyUnicode_FromFormat("<fastcall.Entry %.*s of %R>", e->nargs, e->spec, e->dispatcher);
}

static PyMemberDef entry_members[] = {
    {"dispatcher", T_OBJECT_EX, offsetof(Entry, dispatcher), READONLY,
     "numba's dispatcher, which every call not of the signature goes to"},
    {NULL}
};

static PyTypeObject EntryType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "serial_dynamics.core._fastcall.Entry",
    .tp_doc = "Entry(dispatcher, address, spec): the compiled function at address, called "
              "directly when the arguments are of spec's types, else dispatcher(*args).",
    .tp_basicsize = sizeof(Entry),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_new = entry_new,
    .tp_dealloc = (destructor)entry_dealloc,
    .tp_traverse = (traverseproc)entry_traverse,
    .tp_clear = (inquiry)entry_clear,
    .tp_vectorcall_offset = offsetof(Entry, vectorcall),
    .tp_call = PyVectorcall_Call,
    .tp_repr = (reprfunc)entry_repr,
    .tp_members = entry_members,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fastcall",
    "Single-state entry points called without numba's dispatcher (core.dispatch).", -1, NULL,
};

PyMODINIT_FUNC PyInit__fastcall(void)
{
    import_array();
    if (PyType_Ready(&EntryType) < 0)
        return NULL;
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    Py_INCREF(&EntryType);
    if (PyModule_AddObject(m, "Entry", (PyObject *)&EntryType) < 0) {
        Py_DECREF(&EntryType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
