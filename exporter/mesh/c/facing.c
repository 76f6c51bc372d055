/* Slit points between back-to-back faces (exporter/mesh/slits.py's _facing_partner, formerly
 * numpy): a (border side, vertex) pair is "facing" when a border side ending at the vertex lies
 * on a face turned against the pair's side's face, the dot product of their unit normals below
 * -0.5. Unit normal: (b - a) x (c - a) divided by max(its length, 1e-30), the arithmetic of
 * geometry.cross_rows / row_norms (squares summed left to right) and numpy's maximum; the dot
 * product is summed left to right as numpy's sum over a row of three.
 * positions (k, 3) float64 metres (building-local East/Up/North), faces (m, 3) int64, sides
 * 3 f + i (from corner i of face f to corner i + 1).
 */
#include "faces.h"

static void unit_normal(const double *p, const int64_t *face, double *n) {
    double cross[3];
    face_cross(p, face, cross);
    double x = cross[0], y = cross[1], z = cross[2];
    double length = sqrt((x * x + y * y) + z * z);
    double d = np_maximum(length, 1e-30);
    n[0] = x / d;
    n[1] = y / d;
    n[2] = z / d;
}

/* facing(positions (k, 3) float64, faces (m, 3) int64, sides (s,) int64, start (s,) int64,
 * end (s,) int64, side (p,) int64, vertex (p,) int64) -> (p,) bool: whether pair (side[i],
 * vertex[i]) has a border side (sides[j], from start[j] to end[j]) at vertex[i] on a face turned
 * against side[i]'s face. Every index is checked. */
static PyObject *facing(PyObject *self, PyObject *args) {
    PyObject *o[7], *result = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOO:facing", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6]))
        return NULL;
    const char *K = "facing.facing";
    PyArrayObject *positions = k_array(o[0], NPY_FLOAT64, 2, 0, K, "positions");
    PyArrayObject *faces = k_array(o[1], NPY_INT64, 2, 0, K, "faces");
    PyArrayObject *sides = k_array(o[2], NPY_INT64, 1, 0, K, "sides");
    PyArrayObject *start = k_array(o[3], NPY_INT64, 1, 0, K, "start");
    PyArrayObject *end = k_array(o[4], NPY_INT64, 1, 0, K, "end");
    PyArrayObject *side = k_array(o[5], NPY_INT64, 1, 0, K, "side");
    PyArrayObject *vertex = k_array(o[6], NPY_INT64, 1, 0, K, "vertex");
    PyArrayObject *out = NULL;
    int64_t *first = NULL, *listed = NULL;
    double *normal = NULL;
    if (vertex == NULL) goto done; /* k_array returns NULL at once after an earlier failure */
    npy_intp k = PyArray_DIM(positions, 0), m = PyArray_DIM(faces, 0);
    npy_intp s = PyArray_DIM(sides, 0), p = PyArray_DIM(side, 0);
    if (k_dim(positions, 1, 3, K, "positions") || k_dim(faces, 1, 3, K, "faces") ||
        k_dim(start, 0, s, K, "start") || k_dim(end, 0, s, K, "end") ||
        k_dim(vertex, 0, p, K, "vertex") || k_indices(faces, k, K, "faces") ||
        k_indices(sides, 3 * m, K, "sides") || k_indices(start, k, K, "start") ||
        k_indices(end, k, K, "end") || k_indices(side, 3 * m, K, "side") ||
        k_indices(vertex, k, K, "vertex"))
        goto done;
    npy_intp dims[1] = {p};
    out = k_zeros(1, dims, NPY_BOOL);
    if (out == NULL) goto done;
    first = malloc(sizeof(int64_t) * (size_t)(k + 1));
    listed = malloc(sizeof(int64_t) * (size_t)(2 * s + 1));
    normal = malloc(sizeof(double) * (size_t)(3 * m + 1));
    if (first == NULL || listed == NULL || normal == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *pos = K_F64(positions);
    const int64_t *f = K_I64(faces), *sd = K_I64(sides), *a = K_I64(start), *b = K_I64(end);
    const int64_t *pair_side = K_I64(side), *pair_vertex = K_I64(vertex);
    npy_bool *o_ = K_BOOL(out);
    Py_BEGIN_ALLOW_THREADS
    /* Border sides by vertex (each listed under both its ends): counts, offsets, fill. */
    for (npy_intp v = 0; v <= k; v++) first[v] = 0;
    for (npy_intp j = 0; j < s; j++) {
        first[a[j] + 1]++;
        first[b[j] + 1]++;
    }
    for (npy_intp v = 0; v < k; v++) first[v + 1] += first[v];
    for (npy_intp j = 0; j < s; j++) {
        listed[first[a[j]]++] = sd[j];
        listed[first[b[j]]++] = sd[j];
    }
    for (npy_intp v = k; v > 0; v--) first[v] = first[v - 1]; /* back to the starts */
    first[0] = 0;
    /* Unit normals of the faces with a border side (every face asked about is one). */
    for (npy_intp j = 0; j < s; j++) unit_normal(pos, f + 3 * (sd[j] / 3), normal + 3 * (sd[j] / 3));
    for (npy_intp i = 0; i < p; i++) {
        const double *n1 = normal + 3 * (pair_side[i] / 3);
        for (int64_t q = first[pair_vertex[i]]; q < first[pair_vertex[i] + 1]; q++) {
            const double *n0 = normal + 3 * (listed[q] / 3);
            if ((n0[0] * n1[0] + n0[1] * n1[1]) + n0[2] * n1[2] < -0.5) {
                o_[i] = 1;
                break;
            }
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    free(first);
    free(listed);
    free(normal);
    Py_XDECREF(positions);
    Py_XDECREF(faces);
    Py_XDECREF(sides);
    Py_XDECREF(start);
    Py_XDECREF(end);
    Py_XDECREF(side);
    Py_XDECREF(vertex);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"facing", facing, METH_VARARGS,
     "facing(positions, faces, sides, start, end, side, vertex) -> (p,) bool: slit pairs between "
     "back-to-back faces"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(facing, "Slit points between back-to-back faces.", methods)
