/* Straight chains of a mesh's edges (exporter.mesh.hausdorff._Chains, the module doc's step 2b):
 * edges meeting at a vertex in opposite directions (the cosine of their directions away from it
 * below -straight) are one chain (union-find, union_find.h); each chain's segment runs along its
 * lowest edge's direction through that edge's first end, from the least to the largest
 * projection of its edges' ends, and its slack is the largest distance of those ends to the
 * line plus a rounding margin.
 *
 * Data form: positions (k, 3) float64 metres, faces (m, 3) int64 in [0, k). Edges are the faces'
 * sides as (low, high) vertex pairs, numbered in ascending low * max(k, 1) + high (np.unique's
 * order); chains are numbered in the order of their lowest edge (scipy's connected_components).
 * Every float expression is the former numpy form's, operand for operand: sums over the three
 * coordinates from +0.0 left to right (numpy's add.reduce over a row), np.minimum/np.maximum
 * semantics for the .at reductions, which run in the ends' order (every edge's low end, then
 * every high end). The numpy form is kept in tests/test_chains_kernel.py, which checks this
 * bit for bit. */
#include "kernels.h"
#include "sorted.h"
#include "union_find.h"

/* numpy's .sum(1) of a (n, 3) float64 row: from +0.0, left to right (so a row of -0.0 sums to
 * +0.0, as numpy's does). */
static inline double row_sum(double x, double y, double z) { return ((0.0 + x) + y) + z; }

/* chains(positions (k, 3) float64, faces (m, 3) int64, straight) -> (face_chain (m, 3) int64,
 * start (c, 3) float64, end (c, 3) float64, slack (c,) float64). */
static PyObject *chains(PyObject *self, PyObject *args) {
    PyObject *p_obj, *f_obj, *result = NULL;
    double straight;
    if (!PyArg_ParseTuple(args, "OOd:chains", &p_obj, &f_obj, &straight)) return NULL;
    PyArrayObject *positions = k_array(p_obj, NPY_FLOAT64, 2, 0, "chains.chains", "positions");
    PyArrayObject *faces = k_array(f_obj, NPY_INT64, 2, 0, "chains.chains", "faces");
    PyArrayObject *face_chain = NULL, *start = NULL, *end = NULL, *slack = NULL;
    int64_t *keys = NULL, *order = NULL, *spare = NULL, *edge_of = NULL, *a = NULL, *b = NULL;
    int64_t *parent = NULL, *label = NULL, *lead = NULL, *entry = NULL, *entry_start = NULL;
    double *direction = NULL, *low = NULL, *high = NULL;
    int failed = 0;
    if (positions == NULL || faces == NULL) goto done;
    if (k_dim(positions, 1, 3, "chains.chains", "positions") ||
        k_dim(faces, 1, 3, "chains.chains", "faces"))
        goto done;
    const int64_t k = PyArray_DIM(positions, 0), m = PyArray_DIM(faces, 0);
    if (k_indices(faces, k, "chains.chains", "faces")) goto done;
    const int64_t kk = k > 1 ? k : 1, sides = 3 * m;
    npy_intp face_dims[2] = {m, 3};
    face_chain = k_empty(2, face_dims, NPY_INT64);
    if (face_chain == NULL) goto done;
    const double *P = K_F64(positions);
    const int64_t *F = K_I64(faces);
    int64_t *FC = K_I64(face_chain);
    int64_t e = 0, count = 0;

    Py_BEGIN_ALLOW_THREADS
    keys = malloc((sides + 1) * sizeof(int64_t));
    order = malloc((sides + 1) * sizeof(int64_t));
    spare = malloc((sides + 1) * sizeof(int64_t));
    edge_of = malloc((sides + 1) * sizeof(int64_t));
    a = malloc((sides + 1) * sizeof(int64_t));
    b = malloc((sides + 1) * sizeof(int64_t));
    direction = malloc((3 * sides + 1) * sizeof(double));
    parent = malloc((sides + 1) * sizeof(int64_t));
    label = malloc((sides + 1) * sizeof(int64_t));
    lead = malloc((sides + 1) * sizeof(int64_t));
    entry = malloc((2 * sides + 1) * sizeof(int64_t));
    entry_start = malloc((k + 2) * sizeof(int64_t));
    low = malloc((sides + 1) * sizeof(double));
    high = malloc((sides + 1) * sizeof(double));
    if (!keys || !order || !spare || !edge_of || !a || !b || !direction || !parent || !label ||
        !lead || !entry || !entry_start || !low || !high) {
        failed = 1;
    } else {
        /* Side 3 f + j runs from corner j of face f to the next (faces[:, [0, 1, 1, 2, 2, 0]]). */
        for (int64_t f = 0; f < m; f++) {
            for (int j = 0; j < 3; j++) {
                int64_t u = F[3 * f + j], v = F[3 * f + (j + 1) % 3];
                int64_t lo = u < v ? u : v, hi = u < v ? v : u;
                keys[3 * f + j] = lo * kk + hi;
            }
        }
        int64_t *sorted = stable_order(keys, sides, order, spare);
        /* Unique keys ascending (np.unique) and every side's edge (its inverse). */
        for (int64_t i = 0; i < sides; i++) {
            int64_t side = sorted[i];
            if (i == 0 || keys[side] != keys[sorted[i - 1]]) {
                a[e] = keys[side] / kk;
                b[e] = keys[side] % kk;
                e++;
            }
            edge_of[side] = e - 1;
        }
        /* Unit directions a -> b (0 for a zero-length edge): sqrt((d ** 2).sum(1)). */
        for (int64_t i = 0; i < e; i++) {
            double d[3], length;
            for (int c = 0; c < 3; c++) d[c] = P[3 * b[i] + c] - P[3 * a[i] + c];
            length = sqrt(row_sum(d[0] * d[0], d[1] * d[1], d[2] * d[2]));
            for (int c = 0; c < 3; c++) direction[3 * i + c] = length > 0 ? d[c] / length : 0.0;
        }
        /* Each vertex's entries (edge, +1 leaving from a / -1 from b), by vertex (CSR). */
        for (int64_t v = 0; v <= k + 1; v++) entry_start[v] = 0;
        for (int64_t i = 0; i < e; i++) {
            entry_start[a[i] + 2]++;
            entry_start[b[i] + 2]++;
        }
        for (int64_t v = 2; v <= k + 1; v++) entry_start[v] += entry_start[v - 1];
        for (int64_t i = 0; i < e; i++) entry[entry_start[a[i] + 1]++] = 2 * i;
        for (int64_t i = 0; i < e; i++) entry[entry_start[b[i] + 1]++] = 2 * i + 1;
        /* Pairs of a vertex's entries whose directions away from it are opposite join. */
        for (int64_t i = 0; i < e; i++) parent[i] = i;
        for (int64_t v = 0; v < k; v++) {
            for (int64_t x = entry_start[v]; x < entry_start[v + 1]; x++) {
                int64_t ex = entry[x] >> 1;
                double sx = (entry[x] & 1) ? -1.0 : 1.0;
                for (int64_t y = x + 1; y < entry_start[v + 1]; y++) {
                    int64_t ey = entry[y] >> 1;
                    double sy = (entry[y] & 1) ? -1.0 : 1.0;
                    /* away = +-direction (a negation: exact); (away_x * away_y).sum(1). */
                    const double *dx = direction + 3 * ex, *dy = direction + 3 * ey;
                    double dot = row_sum((sx * dx[0]) * (sy * dy[0]), (sx * dx[1]) * (sy * dy[1]),
                                         (sx * dx[2]) * (sy * dy[2]));
                    if (dot < -straight) uf_join(parent, ex, ey);
                }
            }
        }
        /* Components numbered by their lowest edge (the root: uf_join keeps the lower one). */
        for (int64_t i = 0; i < e; i++) {
            int64_t root = uf_root(parent, i);
            if (root == i) {
                lead[count] = i;
                label[i] = count++;
            } else {
                label[i] = label[root];
            }
        }
        for (int64_t s = 0; s < sides; s++) FC[s] = label[edge_of[s]];
        for (int64_t c = 0; c < count; c++) {
            low[c] = INFINITY;
            high[c] = -INFINITY;
        }
    }
    Py_END_ALLOW_THREADS
    if (failed) {
        PyErr_NoMemory();
        goto done;
    }
    npy_intp seg_dims[2] = {count, 3}, slack_dims[1] = {count};
    start = k_empty(2, seg_dims, NPY_FLOAT64);
    end = k_empty(2, seg_dims, NPY_FLOAT64);
    slack = k_zeros(1, slack_dims, NPY_FLOAT64);
    if (start == NULL || end == NULL || slack == NULL) goto done;
    double *S = K_F64(start), *E = K_F64(end), *L = K_F64(slack);

    Py_BEGIN_ALLOW_THREADS
    /* Every edge's low end, then every high end (np.concatenate([a, b])), against its chain's
     * line through positions[a[lead]] along direction[lead]. */
    for (int pass = 0; pass < 2; pass++) {
        for (int64_t i = 0; i < e; i++) {
            int64_t c = label[i], at = pass ? b[i] : a[i];
            const double *origin = P + 3 * a[lead[c]], *axis = direction + 3 * lead[c];
            double o[3];
            for (int j = 0; j < 3; j++) o[j] = P[3 * at + j] - origin[j];
            double along = row_sum(o[0] * axis[0], o[1] * axis[1], o[2] * axis[2]);
            double squared = row_sum(o[0] * o[0], o[1] * o[1], o[2] * o[2]);
            double across = sqrt(np_maximum(squared - along * along, 0.0));
            low[c] = np_minimum(low[c], along);
            high[c] = np_maximum(high[c], along);
            L[c] = np_maximum(L[c], across);
        }
    }
    for (int64_t c = 0; c < count; c++) {
        const double *origin = P + 3 * a[lead[c]], *axis = direction + 3 * lead[c];
        /* Rounding of the perpendicular distance (sqrt of a difference): a relative margin. */
        L[c] = L[c] + (1e-7 * np_maximum(high[c] - low[c], 0.0) + 1e-12);
        for (int j = 0; j < 3; j++) {
            S[3 * c + j] = origin[j] + low[c] * axis[j];
            E[3 * c + j] = origin[j] + high[c] * axis[j];
        }
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("OOOO", face_chain, start, end, slack);
done:
    free(keys);
    free(order);
    free(spare);
    free(edge_of);
    free(a);
    free(b);
    free(direction);
    free(parent);
    free(label);
    free(lead);
    free(entry);
    free(entry_start);
    free(low);
    free(high);
    Py_XDECREF(positions);
    Py_XDECREF(faces);
    Py_XDECREF(face_chain);
    Py_XDECREF(start);
    Py_XDECREF(end);
    Py_XDECREF(slack);
    return result;
}

static PyMethodDef methods[] = {
    {"chains", chains, METH_VARARGS,
     "chains(positions, faces, straight) -> (face_chain, start, end, slack): straight edge "
     "chains"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(chains, "Straight chains of a mesh's edges (hausdorff._Chains).", methods)
