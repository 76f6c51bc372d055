/* A memo of points, bit for bit: each distinct point (its three float64 coordinates' bits, so
 * -0.0 is not 0.0 and a NaN is itself) gets a row, 0, 1, ... in the order first met.
 *
 * What it serves: a prepared surface (exporter/mesh/distance.py, SurfaceIndex) answers the same
 * per-point queries (the k-d tree's nearest probes, a point's upper bound, its nearest face) for
 * the same points many times: the corners shared by a mesh's triangles, the corners a split
 * triangle hands to its children, the corners the refinement's rounds and the calls of one
 * building meet again. Each answer depends on the point alone, so the Python side keeps one
 * value per row and computes it once (for the rows `lookup` reports as not yet done).
 *
 * Data form: points (p, 3) float64 in any one frame (metres); rows int64. The memo is a capsule
 * owning an open-addressing hash table (linear probing, load at most 1/2) and the points.
 */
#include "kernels.h"

#define MEMO_NAME "exporter.mesh._point_memo.memo"

typedef struct {
    uint64_t *points; /* (count, 3) the coordinates' bits, row after row */
    int64_t count, capacity;
    int64_t *table; /* (slots,) a row, -1 for an empty slot */
    int64_t slots;  /* a power of two */
} memo_t;

static void memo_free(PyObject *capsule) {
    memo_t *memo = (memo_t *)PyCapsule_GetPointer(capsule, MEMO_NAME);
    if (memo == NULL) return;
    free(memo->points);
    free(memo->table);
    free(memo);
}

static inline uint64_t mix(uint64_t h) { /* splitmix64's finaliser */
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    return h ^ (h >> 31);
}

static inline uint64_t point_hash(const uint64_t *p) {
    return mix(mix(mix(p[0]) ^ p[1]) ^ p[2]);
}

/* The slot holding point p, or the empty slot where it goes. */
static inline int64_t find_slot(const memo_t *memo, const uint64_t *p) {
    int64_t mask = memo->slots - 1, slot = (int64_t)(point_hash(p) & (uint64_t)mask);
    for (;;) {
        int64_t row = memo->table[slot];
        if (row < 0) return slot;
        const uint64_t *q = memo->points + 3 * row;
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) return slot;
        slot = (slot + 1) & mask;
    }
}

/* Room for `more` new points: the points grown and the table rehashed (load <= 1/2); -1 when
 * out of memory. */
static int reserve(memo_t *memo, int64_t more) {
    int64_t need = memo->count + more;
    if (need > memo->capacity) {
        int64_t capacity = memo->capacity ? memo->capacity : 64;
        while (capacity < need) capacity *= 2;
        uint64_t *points = realloc(memo->points, (size_t)capacity * 3 * sizeof(uint64_t));
        if (points == NULL) return -1;
        memo->points = points;
        memo->capacity = capacity;
    }
    if (2 * need > memo->slots) {
        int64_t slots = memo->slots ? memo->slots : 128;
        while (slots < 2 * need) slots *= 2;
        int64_t *table = malloc((size_t)slots * sizeof(int64_t));
        if (table == NULL) return -1;
        free(memo->table);
        memo->table = table;
        memo->slots = slots;
        for (int64_t s = 0; s < slots; s++) table[s] = -1;
        for (int64_t row = 0; row < memo->count; row++)
            table[find_slot(memo, memo->points + 3 * row)] = row;
    }
    return 0;
}

/* memo() -> a new, empty memo (a capsule). */
static PyObject *memo(PyObject *self, PyObject *args) {
    memo_t *m = calloc(1, sizeof(memo_t));
    if (m == NULL) return PyErr_NoMemory();
    PyObject *capsule = PyCapsule_New(m, MEMO_NAME, memo_free);
    if (capsule == NULL) free(m);
    return capsule;
}

static memo_t *get_memo(PyObject *obj, const char *kernel) {
    memo_t *m = PyCapsule_IsValid(obj, MEMO_NAME) ? PyCapsule_GetPointer(obj, MEMO_NAME) : NULL;
    if (m == NULL) PyErr_Format(PyExc_ValueError, "%s: memo must be a point_memo.memo()", kernel);
    return m;
}

/* count(memo) -> the number of distinct points met so far. */
static PyObject *count(PyObject *self, PyObject *args) {
    PyObject *memo_obj;
    if (!PyArg_ParseTuple(args, "O:count", &memo_obj)) return NULL;
    memo_t *m = get_memo(memo_obj, "point_memo.count");
    return m == NULL ? NULL : PyLong_FromLongLong((long long)m->count);
}

/* lookup(memo, points (p, 3) float64, done (c,) bool) -> (rows (p,) int64, need (q,) int64):
 * each point's row (new points added, in their order); `need` the index in `points` of the
 * first point of each row whose done flag was False, in the points' order, those flags set to
 * True (the caller fills the rows' values next). ValueError unless c >= count(memo) + p (every
 * row has a flag; checked before any point is added). The memo is used with the GIL held. */
static PyObject *lookup(PyObject *self, PyObject *args) {
    PyObject *memo_obj, *points_obj, *done_obj, *result = NULL;
    const char *kernel = "point_memo.lookup";
    PyArrayObject *rows = NULL, *need = NULL;
    if (!PyArg_ParseTuple(args, "OOO:lookup", &memo_obj, &points_obj, &done_obj)) return NULL;
    memo_t *m = get_memo(memo_obj, kernel);
    if (m == NULL) return NULL;
    PyArrayObject *points = k_array(points_obj, NPY_FLOAT64, 2, 0, kernel, "points");
    PyArrayObject *done = k_array(done_obj, NPY_BOOL, 1, 1, kernel, "done");
    if (points == NULL || done == NULL || k_dim(points, 1, 3, kernel, "points")) goto out;
    npy_intp p = PyArray_DIM(points, 0);
    if (PyArray_DIM(done, 0) < m->count + p) {
        PyErr_Format(PyExc_ValueError, "%s: done holds %zd flags, fewer than the %lld rows the "
                     "points may reach", kernel, (Py_ssize_t)PyArray_DIM(done, 0),
                     (long long)(m->count + p));
        goto out;
    }
    npy_intp dims[1] = {p};
    rows = k_empty(1, dims, NPY_INT64);
    if (rows == NULL) goto out;
    if (reserve(m, p)) {
        PyErr_NoMemory();
        goto out;
    }
    const uint64_t *pt = (const uint64_t *)PyArray_DATA(points);
    int64_t *r = K_I64(rows), q = 0;
    npy_bool *d = K_BOOL(done);
    for (npy_intp i = 0; i < p; i++) {
        const uint64_t *x = pt + 3 * i;
        int64_t slot = find_slot(m, x);
        if (m->table[slot] < 0) {
            memcpy(m->points + 3 * m->count, x, 3 * sizeof(uint64_t));
            m->table[slot] = m->count++;
        }
        r[i] = m->table[slot];
        if (!d[r[i]]) {
            d[r[i]] = 1;
            r[i] = -1 - r[i]; /* marked: a first point of a needed row (restored below) */
            q++;
        }
    }
    dims[0] = q;
    need = k_empty(1, dims, NPY_INT64);
    if (need == NULL) { /* no values will come: the flags set above are cleared again */
        for (npy_intp i = 0; i < p; i++)
            if (r[i] < 0) d[-1 - r[i]] = 0;
        goto out;
    }
    int64_t *n = K_I64(need);
    q = 0;
    for (npy_intp i = 0; i < p; i++) {
        if (r[i] < 0) {
            r[i] = -1 - r[i];
            n[q++] = (int64_t)i;
        }
    }
    result = Py_BuildValue("OO", rows, need);
out:
    Py_XDECREF(points);
    Py_XDECREF(done);
    Py_XDECREF(rows);
    Py_XDECREF(need);
    return result;
}

static PyMethodDef methods[] = {
    {"memo", memo, METH_NOARGS, "memo(): a new, empty memo of points"},
    {"count", count, METH_VARARGS, "count(memo): the number of distinct points met"},
    {"lookup", lookup, METH_VARARGS,
     "lookup(memo, points, done): each point's row and the first point of each row not done"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(point_memo, "A memo of points, bit for bit: a row per distinct point.", methods)
