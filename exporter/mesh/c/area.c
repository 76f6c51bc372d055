/* Triangle areas: 0.5 |(b - a) x (c - a)| per face of an indexed mesh, the arithmetic of the
 * numpy form (exporter/simplify/protect.py's former face_areas: geometry.cross_rows, then
 * geometry.row_norms' sqrt of the squares summed left to right), so the areas are the same bits;
 * positions (n, 3) float64 metres in any one frame, faces (m, 3) int64. And the sign of every
 * face's UV area (quadric.uv_signs' former numpy form): corner_uvs (m, 3, 2) float32, glTF UV
 * convention. And the row-wise cross product of two (m, 3) float64 arrays.
 */
#include "faces.h"

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
        double n[3];
        face_cross(p, f + 3 * i, n);
        out[i] = 0.5 * sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);
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

/* cross_rows(u (m, 3) float64, v (m, 3) float64) -> (m, 3) float64: u x v row by row, the
 * expressions of geometry.cross_rows' numpy form. */
static PyObject *cross_rows(PyObject *self, PyObject *args) {
    PyObject *u_obj, *v_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OO:cross_rows", &u_obj, &v_obj)) return NULL;
    PyArrayObject *u = k_array(u_obj, NPY_FLOAT64, 2, 0, "area.cross_rows", "u");
    PyArrayObject *v = k_array(v_obj, NPY_FLOAT64, 2, 0, "area.cross_rows", "v");
    PyArrayObject *out = NULL;
    if (u == NULL || v == NULL) goto done;
    npy_intp m = PyArray_DIM(u, 0);
    if (k_dim(u, 1, 3, "area.cross_rows", "u") || k_dim(v, 0, m, "area.cross_rows", "v") ||
        k_dim(v, 1, 3, "area.cross_rows", "v"))
        goto done;
    npy_intp dims[2] = {m, 3};
    out = k_empty(2, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *a = K_F64(u), *b = K_F64(v);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < 3 * m; i += 3) {
        o[i] = a[i + 1] * b[i + 2] - a[i + 2] * b[i + 1];
        o[i + 1] = a[i + 2] * b[i] - a[i] * b[i + 2];
        o[i + 2] = a[i] * b[i + 1] - a[i + 1] * b[i];
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(u);
    Py_XDECREF(v);
    Py_XDECREF(out);
    return result;
}

/* uv_signs(corner_uvs (m, 3, 2) float32) -> (m,) int8: the sign of (uv1 - uv0) x (uv2 - uv0),
 * differences in float32 widened to float64 (as numpy's astype after the subtraction), 0 below
 * 1e-12 in magnitude and for NaN (numpy's int8 cast of sign(NaN) on x86-64). */
static PyObject *uv_signs(PyObject *self, PyObject *args) {
    PyObject *uvs_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "O:uv_signs", &uvs_obj)) return NULL;
    PyArrayObject *uvs = k_array(uvs_obj, NPY_FLOAT32, 3, 0, "area.uv_signs", "corner_uvs");
    PyArrayObject *signs = NULL;
    if (uvs == NULL) goto done;
    if (k_dim(uvs, 1, 3, "area.uv_signs", "corner_uvs") ||
        k_dim(uvs, 2, 2, "area.uv_signs", "corner_uvs"))
        goto done;
    npy_intp m = PyArray_DIM(uvs, 0);
    npy_intp dims[1] = {m};
    signs = k_empty(1, dims, NPY_INT8);
    if (signs == NULL) goto done;
    const float *uv = K_F32(uvs);
    int8_t *out = (int8_t *)PyArray_DATA(signs);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++) {
        const float *c = uv + 6 * i;
        float d1u = c[2] - c[0], d1v = c[3] - c[1], d2u = c[4] - c[0], d2v = c[5] - c[1];
        double cross = (double)d1u * (double)d2v - (double)d1v * (double)d2u;
        out[i] = fabs(cross) < 1e-12 ? 0 : cross > 0 ? 1 : cross < 0 ? -1 : 0;
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)signs;
    signs = NULL;
done:
    Py_XDECREF(uvs);
    Py_XDECREF(signs);
    return result;
}

static PyMethodDef methods[] = {
    {"face_areas", face_areas, METH_VARARGS,
     "face_areas(positions, faces) -> (m,) float64: the area of every triangle"},
    {"cross_rows", cross_rows, METH_VARARGS,
     "cross_rows(u, v) -> (m, 3) float64: u x v row by row"},
    {"uv_signs", uv_signs, METH_VARARGS,
     "uv_signs(corner_uvs) -> (m,) int8: the sign of every face's UV area"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(area, "Triangle areas (3-D, and the sign in UV space), numpy's arithmetic.", methods)
