/* serial_dynamics.core._fastcall: a single-state entry point called through its numba.cfunc
 * wrapper, past numba's dispatcher.
 *
 * Why: numba's dispatcher takes ~95-110 ns for a call's first array argument and ~33-35 ns
 * for each further one (bench/bench_call_cost.py), more than the arithmetic of a small
 * robot. An Entry checks in C that every argument is of the entry point's one signature
 * and calls the C function numba compiled for it with numba.cfunc (core/cabi.py: numba's
 * documented C callbacks), whose one C signature is
 *     int64 f(double **data, int64 *dims, int64 *ints)
 * data: the arrays' data pointers in argument order; dims: their shapes, one after the
 * other; ints: the int64 arguments. Any other arguments (another type, dtype, ndim or
 * layout, a read-only or misaligned array, an ndarray subclass, a bool) return OTHER_TYPES
 * without numba being called; a call with keywords or another number of arguments raises
 * a TypeError. When the kernel raised, the wrapper returns RAISED (core/cabi.py) and the
 * call is made again through the njit kernel, which raises the exception as numba does.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stddef.h>
#include <stdint.h>
#include <structmember.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>
#include <numpy/arrayscalars.h>

#define MAX_ARGS 16            /* arguments of an entry point */
#define OTHER_TYPES 3          /* core/status.py */
#define RAISED INT64_MIN       /* core/cabi.py */

typedef int64_t (*cabi)(double **data, int64_t *dims, int64_t *ints);

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *kernel;          /* the njit kernel: called again when the wrapper raised */
    cabi native;               /* the cfunc wrapper's C function */
    int nargs;
    char spec[MAX_ARGS];       /* per argument: 1, 2 or 3 (a float64 array of that ndim), i (int64) */
} Entry;

/* Whether o is an ndarray (not a subclass) of native float64, C-contiguous, aligned,
 * writable and of ndim nd; if so its data pointer goes to *data and its shape to dims. */
static inline int put_array(PyObject *o, int nd, double **data, int64_t *dims)
{
    if (!PyArray_CheckExact(o))
        return 0;
    PyArrayObject *x = (PyArrayObject *)o;
    if (PyArray_NDIM(x) != nd || PyArray_TYPE(x) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(x)
        || !PyArray_CHKFLAGS(x, NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED | NPY_ARRAY_WRITEABLE))
        return 0;
    *data = (double *)PyArray_DATA(x);
    for (int d = 0; d < nd; d++)
        dims[d] = (int64_t)PyArray_DIM(x, d);
    return 1;
}

/* Whether o is a Python int (not a bool) that fits an int64, or an np.int64; its value
 * goes to *v. */
static inline int put_int(PyObject *o, int64_t *v)
{
    if (PyLong_CheckExact(o)) {
        int overflow;
        long long x = PyLong_AsLongLongAndOverflow(o, &overflow);
        if (overflow || (x == -1 && PyErr_Occurred())) {
            PyErr_Clear();
            return 0;
        }
        *v = (int64_t)x;
        return 1;
    }
    if (Py_TYPE(o) == &PyInt64ArrType_Type) {
        *v = (int64_t)PyArrayScalar_VAL(o, Int64);
        return 1;
    }
    return 0;
}

static PyObject *entry_vectorcall(PyObject *self, PyObject *const *args, size_t nargsf,
                                  PyObject *kwnames)
{
    Entry *e = (Entry *)self;
    Py_ssize_t n = PyVectorcall_NARGS(nargsf);
    double *data[MAX_ARGS];
    int64_t dims[3 * MAX_ARGS], ints[MAX_ARGS];
    int a = 0, d = 0, k = 0;
    if (kwnames != NULL || n != e->nargs) {
        PyErr_Format(PyExc_TypeError, "%R takes %d positional arguments (%zd given%s)", self,
                     e->nargs, n, kwnames != NULL ? ", and keywords" : "");
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        char c = e->spec[i];
        int ok = c == 'i' ? put_int(args[i], &ints[k++])
                          : put_array(args[i], c - '0', &data[a++], &dims[d]);
        if (!ok)
            return PyLong_FromLong(OTHER_TYPES);
        d += c == 'i' ? 0 : c - '0';
    }
    int64_t status = e->native(data, dims, ints);
    if (status != RAISED)
        return PyLong_FromLongLong((long long)status);
    return PyObject_Vectorcall(e->kernel, args, nargsf, NULL);    /* raises as numba does */
}

static PyObject *entry_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    PyObject *kernel, *address;
    const char *spec;
    Py_ssize_t len;
    if (!PyArg_ParseTuple(args, "OOs#:Entry", &kernel, &address, &spec, &len))
        return NULL;
    if (len < 1 || len > MAX_ARGS) {
        PyErr_Format(PyExc_ValueError, "Entry: %zd arguments; 1 to %d are supported", len, MAX_ARGS);
        return NULL;
    }
    for (Py_ssize_t i = 0; i < len; i++) {
        if (spec[i] != 'i' && (spec[i] < '1' || spec[i] > '3')) {
            PyErr_Format(PyExc_ValueError, "Entry: spec %R: each argument is 1, 2, 3 (a float64 "
                         "array of that ndim) or i (an int64)", PyTuple_GET_ITEM(args, 2));
            return NULL;
        }
    }
    void *native = PyLong_AsVoidPtr(address);
    if (native == NULL) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "Entry: the address is 0");
        return NULL;
    }
    if (!PyCallable_Check(kernel)) {
        PyErr_SetString(PyExc_TypeError, "Entry: the kernel is not callable");
        return NULL;
    }
    Entry *e = (Entry *)type->tp_alloc(type, 0);
    if (e == NULL)
        return NULL;
    e->vectorcall = entry_vectorcall;
    Py_INCREF(kernel);
    e->kernel = kernel;
    e->native = (cabi)native;
    e->nargs = (int)len;
    memcpy(e->spec, spec, (size_t)len);
    return (PyObject *)e;
}

static int entry_traverse(Entry *e, visitproc visit, void *arg)
{
    Py_VISIT(e->kernel);
    return 0;
}

static int entry_clear(Entry *e)
{
    Py_CLEAR(e->kernel);
    return 0;
}

static void entry_dealloc(Entry *e)
{
    PyObject_GC_UnTrack(e);
    entry_clear(e);
    Py_TYPE(e)->tp_free((PyObject *)e);
}

static PyObject *entry_get_spec(Entry *e, void *closure)
{
    return PyUnicode_FromStringAndSize(e->spec, e->nargs);
}

static PyObject *entry_repr(Entry *e)
{
    PyObject *spec = entry_get_spec(e, NULL);
    if (spec == NULL)
        return NULL;
    PyObject *r = PyUnicode_FromFormat("<fastcall.Entry %U of %R>", spec, e->kernel);
    Py_DECREF(spec);
    return r;
}

static PyMemberDef entry_members[] = {
    {"kernel", T_OBJECT_EX, offsetof(Entry, kernel), READONLY,
     "the njit kernel (numba's dispatcher), called again when the wrapper raised"},
    {NULL}
};

static PyGetSetDef entry_getset[] = {
    {"spec", (getter)entry_get_spec, NULL, "per argument: 1, 2, 3 (a float64 array of that "
     "ndim) or i (an int64)", NULL},
    {NULL}
};

static PyTypeObject EntryType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "serial_dynamics.core._fastcall.Entry",
    .tp_doc = "Entry(kernel, address, spec): the cfunc at address, called when the arguments "
              "are of spec's types, else OTHER_TYPES; kernel(*args) when the cfunc raised.",
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
    .tp_getset = entry_getset,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_fastcall",
    "Single-state entry points called through their numba.cfunc wrappers (core.cabi).", -1, NULL,
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
    /* the calling convention's version (core/cabi.py refuses a build of another one) */
    if (PyModule_AddIntConstant(m, "ABI", 2) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
