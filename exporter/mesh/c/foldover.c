/* The UV-foldover test of the meshopt collapse (exporter/simplify/meshopt.py, formerly numpy):
 * the orientation each wedge's source faces agree on in UV space, and which output faces turn
 * against it. Orientations are signs (-1, 0, 1) of faces' UV areas (quadric.uv_signs); a wedge
 * is a meshopt vertex (one welded vertex, part and UV).
 */
#include "kernels.h"

/* expected(wedge_faces (m, 3) int64, signs (m,) int8, w) -> (w,) int64: per wedge, the sign
 * every face using it has, 0 when they differ or none does. Indices are checked. */
static PyObject *expected(PyObject *self, PyObject *args) {
    PyObject *faces_obj, *signs_obj, *result = NULL;
    Py_ssize_t w;
    if (!PyArg_ParseTuple(args, "OOn:expected", &faces_obj, &signs_obj, &w)) return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, "foldover.expected", "wedge_faces");
    PyArrayObject *signs = k_array(signs_obj, NPY_INT8, 1, 0, "foldover.expected", "signs");
    PyArrayObject *out = NULL;
    int64_t *high = NULL;
    if (faces == NULL || signs == NULL) goto done;
    if (w < 0) {
        PyErr_SetString(PyExc_ValueError, "foldover.expected: w must be >= 0");
        goto done;
    }
    npy_intp m = PyArray_DIM(faces, 0);
    if (k_dim(faces, 1, 3, "foldover.expected", "wedge_faces") ||
        k_dim(signs, 0, m, "foldover.expected", "signs") ||
        k_indices(faces, w, "foldover.expected", "wedge_faces"))
        goto done;
    npy_intp dims[1] = {w};
    out = k_empty(1, dims, NPY_INT64);
    high = malloc(sizeof(int64_t) * (size_t)(w + 1));
    if (out == NULL || high == NULL) {
        if (high == NULL) PyErr_NoMemory();
        goto done;
    }
    int64_t *low = K_I64(out);
    const int64_t *f = K_I64(faces);
    const int8_t *s = (const int8_t *)PyArray_DATA(signs);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < w; i++) {
        low[i] = 2;
        high[i] = -2;
    }
    for (npy_intp i = 0; i < 3 * m; i++) {
        int64_t v = f[i], sign = s[i / 3];
        low[v] = k_imin(low[v], sign);
        high[v] = k_imax(high[v], sign);
    }
    for (npy_intp i = 0; i < w; i++)
        if (low[i] != high[i]) low[i] = 0;
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    free(high);
    Py_XDECREF(faces);
    Py_XDECREF(signs);
    Py_XDECREF(out);
    return result;
}

/* flipped(expected (w,) int64, out (m, 3) int64, signs (m,) int8) -> (m,) bool: output faces
 * (wedge indices) whose UV sign is the opposite of the orientation their corners agree on (the
 * first corner's, else the second's, else the third's; none when all are 0). Indices are
 * checked. */
static PyObject *flipped(PyObject *self, PyObject *args) {
    PyObject *expected_obj, *faces_obj, *signs_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OOO:flipped", &expected_obj, &faces_obj, &signs_obj)) return NULL;
    PyArrayObject *want = k_array(expected_obj, NPY_INT64, 1, 0, "foldover.flipped", "expected");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, "foldover.flipped", "out");
    PyArrayObject *signs = k_array(signs_obj, NPY_INT8, 1, 0, "foldover.flipped", "signs");
    PyArrayObject *out = NULL;
    if (want == NULL || faces == NULL || signs == NULL) goto done;
    npy_intp m = PyArray_DIM(faces, 0);
    if (k_dim(faces, 1, 3, "foldover.flipped", "out") ||
        k_dim(signs, 0, m, "foldover.flipped", "signs") ||
        k_indices(faces, PyArray_DIM(want, 0), "foldover.flipped", "out"))
        goto done;
    npy_intp dims[1] = {m};
    out = k_empty(1, dims, NPY_BOOL);
    if (out == NULL) goto done;
    const int64_t *e = K_I64(want), *f = K_I64(faces);
    const int8_t *s = (const int8_t *)PyArray_DATA(signs);
    npy_bool *o = K_BOOL(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++) {
        int64_t w0 = e[f[3 * i]], w1 = e[f[3 * i + 1]], w2 = e[f[3 * i + 2]];
        int64_t agreed = w0 != 0 ? w0 : (w1 != 0 ? w1 : w2);
        o[i] = agreed != 0 && (int64_t)s[i] == -agreed;
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(want);
    Py_XDECREF(faces);
    Py_XDECREF(signs);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"expected", expected, METH_VARARGS,
     "expected(wedge_faces, signs, w) -> (w,) int64: the UV orientation each wedge's faces agree on"},
    {"flipped", flipped, METH_VARARGS,
     "flipped(expected, out, signs) -> (m,) bool: output faces turned against their corners' orientation"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(foldover, "The UV-foldover test of the meshopt collapse.", methods)
