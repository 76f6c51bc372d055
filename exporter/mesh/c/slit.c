/* Vertices lying inside border sides: every border point against every border side.
 *
 * A point is inside a side (start a, unit direction u, length L) when its offset o = p - a has
 * along = o . u in (tolerance, L - tolerance) and |o|^2 - along^2 <= tolerance^2, and it is
 * neither end of the side. The side's length is geometry.row_norms' arithmetic (the square root of
 * the squares summed x, y, z left to right, as numpy's add.reduce over the rows), at least 1e-30;
 * u is the direction divided by it. The arithmetic and the order of the hits (point by point,
 * sides in order) are those of the former numpy blocks (sums over x, y, z left to right), so the
 * same pairs and parameters come out (tests/test_slits.py, tests/test_slit_kernels.py). Data:
 * positions (k, 3) float64 metres (any one frame), points and side ends as vertex ids.
 */
#include "kernels.h"

/* The hits as growing malloc'd arrays. */
typedef struct {
    int64_t *side, *vertex;
    double *t;
    int64_t count, capacity;
} Hits;

/* Appends a hit; -1 when memory is lacking. */
static int add_hit(Hits *hits, int64_t side, int64_t vertex, double t) {
    if (hits->count == hits->capacity) { /* grow (rare: slits are few) */
        int64_t capacity = 2 * hits->capacity;
        int64_t *s = realloc(hits->side, (size_t)capacity * sizeof(int64_t));
        if (s == NULL) return -1;
        hits->side = s;
        int64_t *v = realloc(hits->vertex, (size_t)capacity * sizeof(int64_t));
        if (v == NULL) return -1;
        hits->vertex = v;
        double *p = realloc(hits->t, (size_t)capacity * sizeof(double));
        if (p == NULL) return -1;
        hits->t = p;
        hits->capacity = capacity;
    }
    hits->side[hits->count] = side;
    hits->vertex[hits->count] = vertex;
    hits->t[hits->count] = t;
    hits->count++;
    return 0;
}

/* The hits of the points ids (p) of positions on the sides start -> end (s); -1 when memory is
 * lacking. */
static int search(const double *positions, const int64_t *ids, int64_t p, const int64_t *start,
                  const int64_t *end, int64_t s, double tolerance, Hits *hits) {
    /* Per side: its start, unit direction and length, one coordinate after the other. */
    double *a = malloc((size_t)(3 * s + 1) * sizeof(double));
    double *unit = malloc((size_t)(3 * s + 1) * sizeof(double));
    double *length = malloc((size_t)(s + 1) * sizeof(double));
    int status = -1;
    if (a == NULL || unit == NULL || length == NULL) goto done;
    for (int64_t j = 0; j < s; j++) {
        const double *pa = positions + 3 * start[j], *pb = positions + 3 * end[j];
        double dx = pb[0] - pa[0], dy = pb[1] - pa[1], dz = pb[2] - pa[2];
        length[j] = k_max(sqrt(dx * dx + dy * dy + dz * dz), 1e-30); /* a NaN stays NaN */
        a[j] = pa[0];
        a[s + j] = pa[1];
        a[2 * s + j] = pa[2];
        unit[j] = dx / length[j];
        unit[s + j] = dy / length[j];
        unit[2 * s + j] = dz / length[j];
    }
    for (int64_t i = 0; i < p; i++) {
        int64_t v = ids[i];
        double px = positions[3 * v], py = positions[3 * v + 1], pz = positions[3 * v + 2];
        for (int64_t j = 0; j < s; j++) {
            double ox = px - a[j], oy = py - a[s + j], oz = pz - a[2 * s + j];
            double along = ox * unit[j] + oy * unit[s + j] + oz * unit[2 * s + j];
            double off2 = ox * ox + oy * oy + oz * oz - along * along;
            if (!(off2 <= tolerance * tolerance)) continue;
            if (!(along > tolerance && along < length[j] - tolerance)) continue;
            if (start[j] == v || end[j] == v) continue;
            if (add_hit(hits, j, v, along / length[j])) goto done;
        }
    }
    status = 0;
done:
    free(a);
    free(unit);
    free(length);
    return status;
}

/* inside(positions (k, 3) float64, ids (p,) int64, start (s,) int64, end (s,) int64, tolerance)
 * -> (side (h,) int64 index into start/end, vertex (h,) int64, t (h,) float64) in point then side
 * order. */
static PyObject *inside(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *ids_obj, *start_obj, *end_obj, *result = NULL;
    double tolerance;
    const char *kernel = "slit.inside";
    PyArrayObject *side = NULL, *vertex = NULL, *t = NULL;
    Hits hits = {NULL, NULL, NULL, 0, 16};
    if (!PyArg_ParseTuple(args, "OOOOd:inside", &positions_obj, &ids_obj, &start_obj, &end_obj,
                          &tolerance))
        return NULL;
    PyArrayObject *positions = k_array(positions_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *ids = k_array(ids_obj, NPY_INT64, 1, 0, kernel, "ids");
    PyArrayObject *start = k_array(start_obj, NPY_INT64, 1, 0, kernel, "start");
    PyArrayObject *end = k_array(end_obj, NPY_INT64, 1, 0, kernel, "end");
    if (positions == NULL || ids == NULL || start == NULL || end == NULL) goto done;
    npy_intp k = PyArray_DIM(positions, 0), p = PyArray_DIM(ids, 0), s = PyArray_DIM(start, 0);
    if (k_dim(positions, 1, 3, kernel, "positions") || k_dim(end, 0, s, kernel, "end") ||
        k_indices(ids, k, kernel, "ids") || k_indices(start, k, kernel, "start") ||
        k_indices(end, k, kernel, "end"))
        goto done;
    int status = -1;
    Py_BEGIN_ALLOW_THREADS
    hits.side = malloc((size_t)hits.capacity * sizeof(int64_t));
    hits.vertex = malloc((size_t)hits.capacity * sizeof(int64_t));
    hits.t = malloc((size_t)hits.capacity * sizeof(double));
    if (hits.side != NULL && hits.vertex != NULL && hits.t != NULL)
        status = search(K_F64(positions), K_I64(ids), p, K_I64(start), K_I64(end), s, tolerance,
                        &hits);
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    npy_intp dims[1] = {hits.count};
    side = k_empty(1, dims, NPY_INT64);
    vertex = k_empty(1, dims, NPY_INT64);
    t = k_empty(1, dims, NPY_FLOAT64);
    if (side == NULL || vertex == NULL || t == NULL) goto done;
    memcpy(K_I64(side), hits.side, (size_t)hits.count * sizeof(int64_t));
    memcpy(K_I64(vertex), hits.vertex, (size_t)hits.count * sizeof(int64_t));
    memcpy(K_F64(t), hits.t, (size_t)hits.count * sizeof(double));
    result = PyTuple_Pack(3, side, vertex, t);
done:
    free(hits.side);
    free(hits.vertex);
    free(hits.t);
    Py_XDECREF(positions);
    Py_XDECREF(ids);
    Py_XDECREF(start);
    Py_XDECREF(end);
    Py_XDECREF(side);
    Py_XDECREF(vertex);
    Py_XDECREF(t);
    return result;
}

static PyMethodDef methods[] = {
    {"inside", inside, METH_VARARGS,
     "inside(positions, ids, start, end, tolerance) -> (side, vertex, t): points strictly "
     "inside sides"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(slit, "Vertices lying inside border sides (the slit search of mesh.slits).", methods)
