/* What every compiled kernel module of exporter.mesh shares: argument checks, Python's min/max,
 * and the module boilerplate.
 *
 * A kernel takes numpy arrays and fills or returns numpy arrays. Its Python wrapper (the
 * exporter/mesh/<algorithm>_kernels.py module) checks the indices and shapes it follows; here each
 * argument is checked for type, dimensions and contiguity, so a wrong one is a ValueError naming
 * the kernel and the argument, never a read past an array. Loops run without the GIL (a Dask
 * worker runs several threads).
 *
 * Floats: every expression keeps the order of operations of the numpy reference it replaces
 * (setup.py turns FMA contraction off), so the results are the same bits.
 */
#ifndef EXPORTER_MESH_KERNELS_H
#define EXPORTER_MESH_KERNELS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <numpy/arrayobject.h>

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Python's (and numba's) min and max of two floats: the first unless the second is strictly
 * smaller (larger). A NaN second argument is ignored, a NaN first one kept, as in Python. */
static inline double k_min(double a, double b) { return b < a ? b : a; }
static inline double k_max(double a, double b) { return b > a ? b : a; }
/* numpy's np.minimum and np.maximum of two floats: NaN when either is. */
static inline double np_minimum(double a, double b) { return (a < b || isnan(a)) ? a : b; }
static inline double np_maximum(double a, double b) { return (a > b || isnan(a)) ? a : b; }
static inline int64_t k_imin(int64_t a, int64_t b) { return b < a ? b : a; }
static inline int64_t k_imax(int64_t a, int64_t b) { return b > a ? b : a; }

/* Python's floor division and modulo for int64 (C's / and % truncate towards zero). */
static inline int64_t k_floordiv(int64_t a, int64_t b) {
    int64_t q = a / b;
    return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}
static inline int64_t k_mod(int64_t a, int64_t b) {
    int64_t r = a % b;
    return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r;
}

static inline const char *k_type_name(int typenum) {
    switch (typenum) {
    case NPY_FLOAT64: return "float64";
    case NPY_FLOAT32: return "float32";
    case NPY_INT64: return "int64";
    case NPY_INT32: return "int32";
    case NPY_BOOL: return "bool";
    case NPY_UINT8: return "uint8";
    default: return "array";
    }
}

/* Argument `name` of `kernel` as a C-contiguous array of `typenum` with `ndim` dimensions (-1:
 * any), a new reference; NULL with a ValueError otherwise. An input (writable == 0) of another
 * type is converted when numpy casts it safely; an output (writable != 0) must already be a
 * writable C-contiguous array of that type, since the kernel writes into it. Returns NULL at once
 * when an error is already set, so a kernel can fetch all its arguments and test once. */
static inline PyArrayObject *k_array(PyObject *obj, int typenum, int ndim, int writable,
                              const char *kernel, const char *name) {
    PyArrayObject *array;
    if (PyErr_Occurred()) return NULL;
    if (writable) {
        if (!PyArray_Check(obj) || PyArray_TYPE((PyArrayObject *)obj) != typenum ||
            !PyArray_IS_C_CONTIGUOUS((PyArrayObject *)obj) ||
            !PyArray_ISWRITEABLE((PyArrayObject *)obj)) {
            PyErr_Format(PyExc_ValueError,
                         "%s: %s must be a writable C-contiguous %s array", kernel, name,
                         k_type_name(typenum));
            return NULL;
        }
        Py_INCREF(obj);
        array = (PyArrayObject *)obj;
    } else {
        array = (PyArrayObject *)PyArray_FROM_OTF(obj, typenum, NPY_ARRAY_IN_ARRAY);
        if (array == NULL) {
            PyErr_Clear();
            PyErr_Format(PyExc_ValueError, "%s: %s must be an array castable to %s", kernel, name,
                         k_type_name(typenum));
            return NULL;
        }
    }
    if (ndim >= 0 && PyArray_NDIM(array) != ndim) {
        PyErr_Format(PyExc_ValueError, "%s: %s must have %d dimensions, not %d", kernel, name,
                     ndim, PyArray_NDIM(array));
        Py_DECREF(array);
        return NULL;
    }
    return array;
}

/* 0 when dimension `axis` of `array` is `size`, else -1 with a ValueError. */
static inline int k_dim(PyArrayObject *array, int axis, npy_intp size, const char *kernel,
                 const char *name) {
    if (PyArray_DIM(array, axis) != size) {
        PyErr_Format(PyExc_ValueError, "%s: %s has %zd along axis %d, expected %zd", kernel, name,
                     (Py_ssize_t)PyArray_DIM(array, axis), axis, (Py_ssize_t)size);
        return -1;
    }
    return 0;
}

/* 0 when every value of the int64 `array` lies in [0, bound), else -1 with a ValueError. */
static inline int k_indices(PyArrayObject *array, int64_t bound, const char *kernel, const char *name) {
    const int64_t *v = (const int64_t *)PyArray_DATA(array);
    npy_intp n = PyArray_SIZE(array);
    for (npy_intp i = 0; i < n; i++) {
        if (v[i] < 0 || v[i] >= bound) {
            PyErr_Format(PyExc_ValueError, "%s: %s holds %lld, outside [0, %lld)", kernel, name,
                         (long long)v[i], (long long)bound);
            return -1;
        }
    }
    return 0;
}

/* A new C-contiguous array of `typenum`, zero-filled; NULL with MemoryError. */
static inline PyArrayObject *k_zeros(int ndim, const npy_intp *dims, int typenum) {
    return (PyArrayObject *)PyArray_ZEROS(ndim, (npy_intp *)dims, typenum, 0);
}

/* A new C-contiguous array of `typenum`, uninitialised; NULL with MemoryError. */
static inline PyArrayObject *k_empty(int ndim, const npy_intp *dims, int typenum) {
    return (PyArrayObject *)PyArray_EMPTY(ndim, (npy_intp *)dims, typenum, 0);
}

#define K_F64(a) ((double *)PyArray_DATA(a))
#define K_F32(a) ((float *)PyArray_DATA(a))
#define K_I64(a) ((int64_t *)PyArray_DATA(a))
#define K_I32(a) ((int32_t *)PyArray_DATA(a))
#define K_BOOL(a) ((npy_bool *)PyArray_DATA(a))

/* The module's init function: `PyInit__<algorithm>` for exporter.mesh._<algorithm>. */
#define K_MODULE(algorithm, doc, methods)                                                   \
    static struct PyModuleDef k_module_def = {PyModuleDef_HEAD_INIT, "_" #algorithm, doc,   \
                                              -1, methods};                                 \
    PyMODINIT_FUNC PyInit__##algorithm(void) {                                              \
        import_array();                                                                     \
        return PyModule_Create(&k_module_def);                                              \
    }

#endif
