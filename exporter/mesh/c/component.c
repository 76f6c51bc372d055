/* Connected components of an undirected graph: union-find (union_find.h), each union linking the
 * larger root under the smaller, so every component's root is its lowest node (the labels
 * scipy.sparse.csgraph.connected_components orders its components by). */
#include "kernels.h"
#include "union_find.h"

/* lowest(n, left (e,) int64, right (e,) int64) -> (n,) int64: the lowest node of each node's
 * component. The caller checks that every index is in [0, n). */
static PyObject *lowest(PyObject *self, PyObject *args) {
    PyObject *left_obj, *right_obj, *result = NULL;
    Py_ssize_t n;
    if (!PyArg_ParseTuple(args, "nOO:lowest", &n, &left_obj, &right_obj)) return NULL;
    PyArrayObject *left = k_array(left_obj, NPY_INT64, 1, 0, "component.lowest", "left");
    PyArrayObject *right = k_array(right_obj, NPY_INT64, 1, 0, "component.lowest", "right");
    PyArrayObject *parent = NULL;
    if (left == NULL || right == NULL) goto done;
    if (n < 0) {
        PyErr_SetString(PyExc_ValueError, "component.lowest: n must be >= 0");
        goto done;
    }
    if (k_dim(right, 0, PyArray_DIM(left, 0), "component.lowest", "right") ||
        k_indices(left, n, "component.lowest", "left") ||
        k_indices(right, n, "component.lowest", "right"))
        goto done;
    npy_intp dims[1] = {n};
    parent = k_empty(1, dims, NPY_INT64);
    if (parent == NULL) goto done;
    int64_t *p = K_I64(parent);
    const int64_t *a = K_I64(left), *b = K_I64(right);
    npy_intp edges = PyArray_DIM(left, 0);
    Py_BEGIN_ALLOW_THREADS
    for (int64_t i = 0; i < n; i++) p[i] = i;
    for (npy_intp e = 0; e < edges; e++) uf_join(p, a[e], b[e]);
    /* Parents are lower than their children: one pass in order settles every node. */
    for (int64_t i = 0; i < n; i++) p[i] = p[p[i]];
    Py_END_ALLOW_THREADS
    result = (PyObject *)parent;
    parent = NULL;
done:
    Py_XDECREF(left);
    Py_XDECREF(right);
    Py_XDECREF(parent);
    return result;
}

static PyMethodDef methods[] = {
    {"lowest", lowest, METH_VARARGS,
     "lowest(n, left, right) -> (n,) int64: the lowest node of each node's component"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(component, "Connected components by union-find, labelled by their lowest node.", methods)
