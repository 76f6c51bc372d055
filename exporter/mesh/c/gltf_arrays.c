/* A part's vertex data in glTF's frame, in one pass per array: the (n, 3) float32 positions with
 * X negated, the (n, 3) float32 unit normals with X negated (rows without a direction: +Y), and
 * the flat uint16/uint32 index array with every triangle (a, b, c) written (a, c, b).
 *
 * Frames: local East/Up/North metres in, glTF (West, Up, North) metres out; negating X is a
 * reflection, hence the reversed triangles (exporter/gltf_writer.py explains the convention).
 *
 * Same bits as the numpy formulation it replaces (tests/gltf_reference.py, reference_gltf_arrays):
 * positions are rounded float64 -> float32 then multiplied by -1; a normal is widened to float64,
 * its length is sqrt((x*x + y*y) + z*z) (the order np.linalg.norm(axis=1) sums in), the row is
 * divided by it when that is finite and > 1e-12 (else zero), a zero row becomes (0, 1, 0), then
 * the row is rounded to float32 and X multiplied by -1. Indices are cast as numpy's astype casts
 * (modulo 2^16 or 2^32; the caller picks uint16 only for at most 65535 vertices).
 */
#include "kernels.h"

static const char *KERNEL = "gltf_arrays.arrays";

/* arrays(positions (n, 3) float64, normals (n, 3) float32 or float64, triangles (m, 3) int64,
 *        wide) -> (positions (n, 3) float32, normals (n, 3) float32, indices (3m,) uint16 or
 *        uint32 when wide) */
static PyObject *arrays(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *normals_obj, *triangles_obj;
    int wide;
    PyArrayObject *positions = NULL, *normals = NULL, *triangles = NULL;
    PyArrayObject *out_positions = NULL, *out_normals = NULL, *out_indices = NULL;
    PyObject *result = NULL;
    if (!PyArg_ParseTuple(args, "OOOp", &positions_obj, &normals_obj, &triangles_obj, &wide))
        return NULL;
    positions = k_array(positions_obj, NPY_FLOAT64, 2, 0, KERNEL, "positions");
    /* float32 normals (what the readers keep) are read as they are: widening is exact. */
    int single = PyArray_Check(normals_obj) &&
                 PyArray_TYPE((PyArrayObject *)normals_obj) == NPY_FLOAT32;
    normals = k_array(normals_obj, single ? NPY_FLOAT32 : NPY_FLOAT64, 2, 0, KERNEL, "normals");
    triangles = k_array(triangles_obj, NPY_INT64, 2, 0, KERNEL, "triangles");
    if (positions == NULL || normals == NULL || triangles == NULL) goto done;
    npy_intp n = PyArray_DIM(positions, 0), m = PyArray_DIM(triangles, 0);
    if (k_dim(positions, 1, 3, KERNEL, "positions") || k_dim(normals, 0, n, KERNEL, "normals") ||
        k_dim(normals, 1, 3, KERNEL, "normals") || k_dim(triangles, 1, 3, KERNEL, "triangles"))
        goto done;
    npy_intp dims[2] = {n, 3}, flat = 3 * m;
    out_positions = k_empty(2, dims, NPY_FLOAT32);
    out_normals = k_empty(2, dims, NPY_FLOAT32);
    out_indices = k_empty(1, &flat, wide ? NPY_UINT32 : NPY_UINT16);
    if (out_positions == NULL || out_normals == NULL || out_indices == NULL) goto done;

    Py_BEGIN_ALLOW_THREADS
    const double *p = K_F64(positions);
    float *op = K_F32(out_positions), *on = K_F32(out_normals);
    for (npy_intp i = 0; i < 3 * n; i += 3) {
        op[i] = (float)p[i] * -1.0f;
        op[i + 1] = (float)p[i + 1];
        op[i + 2] = (float)p[i + 2];
    }
    const float *n32 = single ? K_F32(normals) : NULL;
    const double *n64 = single ? NULL : K_F64(normals);
    for (npy_intp i = 0; i < 3 * n; i += 3) {
        double x = single ? (double)n32[i] : n64[i];
        double y = single ? (double)n32[i + 1] : n64[i + 1];
        double z = single ? (double)n32[i + 2] : n64[i + 2];
        double length = sqrt((x * x + y * y) + z * z);
        double ux = 0.0, uy = 0.0, uz = 0.0;
        if (isfinite(length) && length > 1e-12) {
            ux = x / length;
            uy = y / length;
            uz = z / length;
        }
        if (!(ux != 0.0 || uy != 0.0 || uz != 0.0)) { /* no direction: up */
            ux = 0.0;
            uy = 1.0;
            uz = 0.0;
        }
        on[i] = (float)ux * -1.0f;
        on[i + 1] = (float)uy;
        on[i + 2] = (float)uz;
    }
    const int64_t *t = K_I64(triangles);
    if (wide) {
        uint32_t *oi = (uint32_t *)PyArray_DATA(out_indices);
        for (npy_intp k = 0; k < flat; k += 3) {
            oi[k] = (uint32_t)t[k];
            oi[k + 1] = (uint32_t)t[k + 2];
            oi[k + 2] = (uint32_t)t[k + 1];
        }
    } else {
        uint16_t *oi = (uint16_t *)PyArray_DATA(out_indices);
        for (npy_intp k = 0; k < flat; k += 3) {
            oi[k] = (uint16_t)t[k];
            oi[k + 1] = (uint16_t)t[k + 2];
            oi[k + 2] = (uint16_t)t[k + 1];
        }
    }
    Py_END_ALLOW_THREADS

    result = Py_BuildValue("OOO", out_positions, out_normals, out_indices);
done:
    Py_XDECREF(positions);
    Py_XDECREF(normals);
    Py_XDECREF(triangles);
    Py_XDECREF(out_positions);
    Py_XDECREF(out_normals);
    Py_XDECREF(out_indices);
    return result;
}

/* bounds(positions (n, 3) float32, n >= 1) -> (max x, max y, max z, min x, min y, min z): the
 * columns' extremes as np.maximum / np.minimum reduce them (a NaN wins). Which of 0.0 and -0.0 numpy
 * returns for a tie depends on its loop: the caller asks numpy itself when a bound is zero. */
static PyObject *bounds(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "O", &positions_obj)) return NULL;
    PyArrayObject *positions = k_array(positions_obj, NPY_FLOAT32, 2, 0, "gltf_arrays.bounds", "positions");
    if (positions == NULL) return NULL;
    npy_intp n = PyArray_DIM(positions, 0);
    if (k_dim(positions, 1, 3, "gltf_arrays.bounds", "positions")) goto done;
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "gltf_arrays.bounds: positions is empty");
        goto done;
    }
    const float *p = K_F32(positions);
    double top[3], bottom[3];
    for (int c = 0; c < 3; c++) top[c] = bottom[c] = p[c];
    for (npy_intp i = 3; i < 3 * n; i += 3) {
        for (int c = 0; c < 3; c++) {
            top[c] = np_maximum(top[c], p[i + c]);
            bottom[c] = np_minimum(bottom[c], p[i + c]);
        }
    }
    result = Py_BuildValue("(ddd)(ddd)", top[0], top[1], top[2], bottom[0], bottom[1], bottom[2]);
done:
    Py_DECREF(positions);
    return result;
}

static PyMethodDef methods[] = {
    {"arrays", arrays, METH_VARARGS,
     "arrays(positions, normals, triangles, wide) -> (positions, normals, indices): glTF frame."},
    {"bounds", bounds, METH_VARARGS,
     "bounds(positions) -> ((max x, y, z), (min x, y, z)) of (n, 3) float32 positions."},
    {NULL, NULL, 0, NULL},
};

K_MODULE(gltf_arrays, "A part's vertex data in glTF's frame (exporter/mesh/c/gltf_arrays.c).",
         methods)
