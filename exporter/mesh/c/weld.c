/* Equal and near float rows: exact-duplicate clusters (a hash of the rows), unique rows in
 * lexicographic order (a stable merge sort of row indices), and the components of the graph of
 * points closer than a distance (a sweep along a generic direction, union-find: union_find.h).
 *
 * Rows are (n, w) float64, C order, any one frame and unit. Two rows are equal when every column
 * compares equal (==, as numpy compares them: -0.0 equals 0.0, a NaN equals nothing, so a row
 * holding a NaN is a cluster of its own). The sort orders columns as numpy's float sort does (a
 * NaN after every number, NaNs tied), the first column first, ties in input order, which is
 * np.lexsort(keys.T[::-1]); with the equality above this is np.unique(keys, axis=0,
 * return_index=True, return_inverse=True) without its sort of a structured view
 * (tests/test_weld_kernels.py checks both against the numpy forms, bit for bit). Near points
 * are joined by scipy's cKDTree.query_pairs distance test, computed alike (same test file).
 */
#include "kernels.h"
#include "sorted.h"
#include "union_find.h"

#include <float.h>

/* Whether rows a and b (w columns) are equal column by column. */
static inline int rows_equal(const double *a, const double *b, npy_intp w) {
    for (npy_intp c = 0; c < w; c++)
        if (!(a[c] == b[c])) return 0;
    return 1;
}

/* Whether row a (w columns) holds a NaN. */
static inline int row_has_nan(const double *a, npy_intp w) {
    for (npy_intp c = 0; c < w; c++)
        if (a[c] != a[c]) return 1;
    return 0;
}

/* murmur3's 64-bit finaliser: every input bit moves every output bit. */
static inline uint64_t mix64(uint64_t h) {
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb93fe53a4ec3ULL;
    h ^= h >> 33;
    return h;
}

/* A hash of row a (w columns, no NaN) equal for rows equal by ==: -0.0 hashes as 0.0. */
static inline uint64_t row_hash(const double *a, npy_intp w) {
    uint64_t h = 0x9e3779b97f4a7c15ULL;
    for (npy_intp c = 0; c < w; c++) {
        double x = a[c] == 0.0 ? 0.0 : a[c];
        uint64_t bits;
        memcpy(&bits, &x, sizeof bits);
        h = mix64(h ^ bits) + 0x9e3779b97f4a7c15ULL;
    }
    return h;
}

/* Clusters of equal rows r (n, w) numbered in order of their first (lowest) member: writes each
 * row's cluster to `id` (n) and the clusters' first members to `first`, returns their count. One
 * pass over an open-addressing table (linear probing, at most half full) of those members,
 * `table` (size, a power of 2 >= 2n) as scratch. */
static int64_t exact_clusters(const double *r, npy_intp n, npy_intp w, int64_t *id, int64_t *first,
                              int64_t *table, uint64_t size) {
    int64_t k = 0;
    for (uint64_t s = 0; s < size; s++) table[s] = -1;
    for (npy_intp i = 0; i < n; i++) {
        const double *row = r + i * w;
        uint64_t s = 0;
        if (!row_has_nan(row, w)) {
            s = row_hash(row, w) & (size - 1);
            while (table[s] >= 0 && !rows_equal(r + table[s] * w, row, w))
                s = (s + 1) & (size - 1);
            if (table[s] >= 0) {
                id[i] = id[table[s]];
                continue;
            }
            table[s] = i;
        }
        first[k] = i;
        id[i] = k++;
    }
    return k;
}

/* numpy's float order for sorting: a NaN after every number, NaNs tied. */
static inline int before(double a, double b) { return a < b || (b != b && a == a); }

/* -1, 0 or 1: row a before, tied with or after row b (w columns), the first column first. */
static inline int row_order(const double *a, const double *b, npy_intp w) {
    for (npy_intp c = 0; c < w; c++) {
        if (before(a[c], b[c])) return -1;
        if (before(b[c], a[c])) return 1;
    }
    return 0;
}

/* The first row of each group of equal rows of r (n, w) in their stable lexicographic order,
 * written to `first`, and each row's group to `id` (n); returns the count of groups. `order` and
 * `spare` (n each) are scratch for the sort. */
static int64_t unique_rows(const double *r, npy_intp n, npy_intp w, int64_t *id, int64_t *first,
                           int64_t *order, int64_t *spare) {
    int64_t k = 0;
#define ROW_LE(a, b) (row_order(r + (a) * w, r + (b) * w, w) <= 0)
    K_STABLE_ORDER(n, order, spare, ROW_LE);
#undef ROW_LE
    for (npy_intp t = 0; t < n; t++) {
        if (t == 0 || !rows_equal(r + order[t] * w, r + order[t - 1] * w, w)) first[k++] = order[t];
        id[order[t]] = k - 1;
    }
    return k;
}

/* The kernel `name` (exact or unique) of its rows argument (n, w) float64: returns (id, first)
 * for exact, (first, id) for unique, both int64, id (n,) and first (k,). */
static PyObject *rows_kernel(PyObject *args, int unique) {
    const char *kernel = unique ? "weld.unique" : "weld.exact";
    PyObject *rows_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, unique ? "O:unique" : "O:exact", &rows_obj)) return NULL;
    PyArrayObject *rows = k_array(rows_obj, NPY_FLOAT64, 2, 0, kernel, "rows");
    PyArrayObject *id = NULL, *first = NULL;
    int64_t *scratch = NULL;
    if (rows == NULL) goto done;
    npy_intp n = PyArray_DIM(rows, 0), w = PyArray_DIM(rows, 1);
    npy_intp dims[1] = {n};
    id = k_empty(1, dims, NPY_INT64);
    if (id == NULL) goto done;
    uint64_t size = 16; /* exact's table: a power of 2, at most half full */
    while (size < 2 * (uint64_t)n) size *= 2;
    /* first (n), then the table (size) or the sort's two halves (2n). */
    scratch = malloc(((uint64_t)n + (unique ? 2 * (uint64_t)n + 1 : size)) * sizeof *scratch);
    if (scratch == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *r = K_F64(rows);
    int64_t *ids = K_I64(id), k;
    Py_BEGIN_ALLOW_THREADS
    k = unique ? unique_rows(r, n, w, ids, scratch, scratch + n, scratch + 2 * n)
               : exact_clusters(r, n, w, ids, scratch, scratch + n, size);
    Py_END_ALLOW_THREADS
    dims[0] = k;
    first = k_empty(1, dims, NPY_INT64);
    if (first == NULL) goto done;
    memcpy(K_I64(first), scratch, (size_t)k * sizeof *scratch);
    result = unique ? Py_BuildValue("OO", first, id) : Py_BuildValue("OO", id, first);
done:
    free(scratch);
    Py_XDECREF(rows);
    Py_XDECREF(id);
    Py_XDECREF(first);
    return result;
}

/* exact(rows (n, w) float64) -> (cluster (n,) int64, first (k,) int64): clusters of equal rows
 * numbered in order of their first (lowest) member, and that member per cluster. */
static PyObject *exact(PyObject *self, PyObject *args) { return rows_kernel(args, 0); }

/* unique(rows (n, w) float64) -> (first (k,) int64, inverse (n,) int64): the first row of each
 * group of equal rows in the rows' stable lexicographic order, and each row's group. */
static PyObject *unique(PyObject *self, PyObject *args) { return rows_kernel(args, 1); }

/* A generic direction (1, p^-1, p^-2), p the plastic number: positions sorted along it rarely tie
 * (an axis would put a whole wall at one key). */
#define NEAR_A 1.0
#define NEAR_B 0.7548776662466927
#define NEAR_C 0.5698402909980532

/* near(rows (n, 3) float64, distance) -> (n,) int64 or None: the lowest row of each row's
 * component in the graph joining rows i, j with ((dx*dx + dy*dy) + dz*dz) <= distance*distance
 * (dx = x_i - x_j: scipy's cKDTree.query_pairs test, whose result is exactly this pair set, its
 * boxes bounding every pair's rounded distance). Candidates: rows sorted by their key along the
 * direction above, each paired with the next ones whose key is within a bound of what such a pair
 * can differ by (the distance plus the keys' rounding). None when a coordinate or the distance is
 * not finite (the caller then asks the tree). */
static PyObject *near(PyObject *self, PyObject *args) {
    PyObject *rows_obj, *result = NULL;
    double distance;
    if (!PyArg_ParseTuple(args, "Od:near", &rows_obj, &distance)) return NULL;
    PyArrayObject *rows = k_array(rows_obj, NPY_FLOAT64, 2, 0, "weld.near", "rows");
    PyArrayObject *lowest = NULL;
    int64_t *scratch = NULL;
    double *key = NULL;
    if (rows == NULL || k_dim(rows, 1, 3, "weld.near", "rows")) goto done;
    npy_intp n = PyArray_DIM(rows, 0);
    const double *r = K_F64(rows);
    double largest = 0.0; /* the largest coordinate's size; infinite if one is not finite */
    for (npy_intp i = 0; i < 3 * n; i++) {
        double size = fabs(r[i]);
        if (!(size <= DBL_MAX)) largest = INFINITY;
        else if (size > largest) largest = size;
    }
    if (!isfinite(largest) || !isfinite(distance)) {
        result = Py_None;
        Py_INCREF(result);
        goto done;
    }
    npy_intp dims[1] = {n};
    lowest = k_empty(1, dims, NPY_INT64);
    scratch = malloc((2 * (size_t)n + 1) * sizeof *scratch);
    key = malloc(((size_t)n + 1) * sizeof *key);
    if (lowest == NULL) goto done;
    if (scratch == NULL || key == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    int64_t *parent = K_I64(lowest), *order = scratch, *spare = scratch + n;
    const double bound = distance * distance;
    /* A joined pair has |dx|, |dy|, |dz| <= ~distance (or a tiny one whose square underflows), so
     * keys within (A + B + C) times that, plus each key's rounding (a few ulps of the largest
     * coordinate); 2x and 64 ulps to spare. */
    const double reach = (NEAR_A + NEAR_B + NEAR_C) *
                         (2.0 * (distance > 1e-150 ? distance : 1e-150) + 64.0 * DBL_EPSILON * largest);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < n; i++) {
        parent[i] = i;
        key[i] = NEAR_A * r[3 * i] + NEAR_B * r[3 * i + 1] + NEAR_C * r[3 * i + 2];
    }
#define KEY_LE(a, b) (key[a] <= key[b])
    K_STABLE_ORDER(n, order, spare, KEY_LE);
#undef KEY_LE
    for (npy_intp t = 0; t < n; t++) {
        const double *a = r + 3 * order[t];
        for (npy_intp u = t + 1; u < n && key[order[u]] - key[order[t]] <= reach; u++) {
            const double *b = r + 3 * order[u];
            double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
            double d = 0.0;
            d += dx * dx;
            d += dy * dy;
            d += dz * dz;
            if (d <= bound) uf_join(parent, order[t], order[u]);
        }
    }
    /* Parents are lower than their children: one pass in order settles every row. */
    for (npy_intp i = 0; i < n; i++) parent[i] = parent[parent[i]];
    Py_END_ALLOW_THREADS
    result = (PyObject *)lowest;
    lowest = NULL;
done:
    free(scratch);
    free(key);
    Py_XDECREF(rows);
    Py_XDECREF(lowest);
    return result;
}

static PyMethodDef methods[] = {
    {"exact", exact, METH_VARARGS,
     "exact(rows) -> (cluster, first): clusters of equal rows by first member, and those members"},
    {"unique", unique, METH_VARARGS,
     "unique(rows) -> (first, inverse): unique rows in lexicographic order, first occurrences"},
    {"near", near, METH_VARARGS,
     "near(rows, distance) -> (n,) int64 or None: lowest row of each row's near-component"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(weld, "Equal float64 rows: exact-duplicate clusters and lexicographic unique rows.",
         methods)
