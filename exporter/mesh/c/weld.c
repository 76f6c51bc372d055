/* Equal float rows: exact-duplicate clusters (a hash of the rows) and unique rows in lexicographic
 * order (a stable merge sort of row indices).
 *
 * Rows are (n, w) float64, C order, any one frame and unit. Two rows are equal when every column
 * compares equal (==, as numpy compares them: -0.0 equals 0.0, a NaN equals nothing, so a row
 * holding a NaN is a cluster of its own). The sort orders columns as numpy's float sort does (a
 * NaN after every number, NaNs tied), the first column first, ties in input order, which is
 * np.lexsort(keys.T[::-1]); with the equality above this is np.unique(keys, axis=0,
 * return_index=True, return_inverse=True) without its sort of a structured view
 * (tests/test_weld_kernels.py checks both against the numpy forms, bit for bit).
 */
#include "kernels.h"
#include "sorted.h"

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

static PyMethodDef methods[] = {
    {"exact", exact, METH_VARARGS,
     "exact(rows) -> (cluster, first): clusters of equal rows by first member, and those members"},
    {"unique", unique, METH_VARARGS,
     "unique(rows) -> (first, inverse): unique rows in lexicographic order, first occurrences"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(weld, "Equal float64 rows: exact-duplicate clusters and lexicographic unique rows.",
         methods)
