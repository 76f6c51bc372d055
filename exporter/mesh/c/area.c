/* Triangle areas of an indexed mesh: 0.5 |(b - a) x (c - a)| per face, the arithmetic of the
 * numpy form (exporter/simplify/protect.py's former face_areas: geometry.cross_rows, then
 * geometry.row_norms' sqrt of the squares summed left to right), so the areas are the same bits.
 * positions (n, 3) float64 metres in any one frame, faces (m, 3) int64.
 */
#include "kernels.h"

/* face_areas(positions (n, 3) float64, faces (m, 3) int64) -> (m,) float64 square metres.
 * Every face index is checked against n. */
static PyObject *face_areas(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *faces_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OO:face_areas", &positions_obj, &faces_obj)) return NULL;
    PyArrayObject *positions = k_array(positions_obj, NPY_FLOAT64, 2, 0, "area.face_areas", "positions");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, "area.face_areas", "faces");
    PyArrayObject *areas = NULL;
    if (positions == NULL || faces == NULL) goto done;
    if (k_dim(positions, 1, 3, "area.face_areas", "positions") ||
        k_dim(faces, 1, 3, "area.face_areas", "faces") ||
        k_indices(faces, PyArray_DIM(positions, 0), "area.face_areas", "faces"))
        goto done;
    npy_intp m = PyArray_DIM(faces, 0);
    npy_intp dims[1] = {m};
    areas = k_empty(1, dims, NPY_FLOAT64);
    if (areas == NULL) goto done;
    const double *p = K_F64(positions);
    const int64_t *f = K_I64(faces);
    double *out = K_F64(areas);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++) {
        const double *a = p + 3 * f[3 * i], *b = p + 3 * f[3 * i + 1], *c = p + 3 * f[3 * i + 2];
        double u0 = b[0] - a[0], u1 = b[1] - a[1], u2 = b[2] - a[2];
        double v0 = c[0] - a[0], v1 = c[1] - a[1], v2 = c[2] - a[2];
        double x = u1 * v2 - u2 * v1, y = u2 * v0 - u0 * v2, z = u0 * v1 - u1 * v0;
        out[i] = 0.5 * sqrt((x * x + y * y) + z * z);
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)areas;
    areas = NULL;
done:
    Py_XDECREF(positions);
    Py_XDECREF(faces);
    Py_XDECREF(areas);
    return result;
}

static PyMethodDef methods[] = {
    {"face_areas", face_areas, METH_VARARGS,
     "face_areas(positions, faces) -> (m,) float64: the area of every triangle"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(area, "Triangle areas of an indexed mesh, numpy's arithmetic.", methods)
