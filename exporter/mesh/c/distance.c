/* Exact distance from points to triangles: one (point, triangle) pair at a time.
 *
 * Source: Ericson, "Real-Time Collision Detection" (2005), 5.1.5 (closest point on a triangle by
 * its Voronoi regions). The regions are tested in the order the former vectorised numpy form
 * applied them (vertex A, B, C, then edges AB, AC, BC, then the interior), with its float
 * operations in its order, so the results are the same bits (tests/test_distance_kernels.py). A
 * degenerate (zero-area) triangle whose formula gives NaN takes its nearest corner's distance.
 * Frame-free: any one Cartesian frame, metres.
 */
#include "point_triangle.h"

/* pairs(points (n, 3) float64, tri (n, 3, 3) float64, out (n,) float64): out[i] is the distance
 * from points[i] to tri[i]. */
static PyObject *pairs(PyObject *self, PyObject *args) {
    PyObject *points_obj, *tri_obj, *out_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OOO:pairs", &points_obj, &tri_obj, &out_obj)) return NULL;
    PyArrayObject *points = k_array(points_obj, NPY_FLOAT64, 2, 0, "distance.pairs", "points");
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, "distance.pairs", "tri");
    PyArrayObject *out = k_array(out_obj, NPY_FLOAT64, 1, 1, "distance.pairs", "out");
    if (points == NULL || tri == NULL || out == NULL) goto done;
    npy_intp n = PyArray_DIM(points, 0);
    if (k_dim(points, 1, 3, "distance.pairs", "points") || k_dim(tri, 0, n, "distance.pairs", "tri") ||
        k_dim(tri, 1, 3, "distance.pairs", "tri") || k_dim(tri, 2, 3, "distance.pairs", "tri") ||
        k_dim(out, 0, n, "distance.pairs", "out"))
        goto done;
    const double *p = K_F64(points), *t = K_F64(tri);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < n; i++) o[i] = pair_distance(p[3 * i], p[3 * i + 1], p[3 * i + 2], t + 9 * i);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    Py_XDECREF(points);
    Py_XDECREF(tri);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"pairs", pairs, METH_VARARGS, "pairs(points, tri, out): out[i] = distance(points[i], tri[i]), metres"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(distance, "Exact point-triangle distance (Ericson 5.1.5), one pair at a time.", methods)
