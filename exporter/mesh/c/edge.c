/* Every face side's undirected edge key in ascending order, and the distinct edges with their use
 * counts.
 *
 * Side 3 f + i of faces (m, 3) int64 runs from corner i of face f to the next; its key is
 * low * vertex_count + high. Sides are bucketed by their lower vertex (counting sort, sides in
 * index order), each bucket sorted stably by the higher vertex (insertion sort: buckets hold a few
 * sides; a merge sort at a fan's apex), so the order is exactly np.argsort(keys, kind="stable")'s
 * (tests/test_edge_kernels.py keeps the numpy form as the reference). Integers only.
 */
#include "faces.h"
#include "kernels.h"
#include "sorted.h"

/* keys (3m,) ascending and order (3m,) the stable permutation of the sides that sorts them, of
 * faces (m, 3) with ids in [0, vertex_count). Returns -1 when scratch memory is lacking. */
static int key_order(const int64_t *faces, int64_t m, int64_t vertex_count, int64_t *keys,
                     int64_t *order) {
    int64_t n = 3 * m;
    int64_t *low = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *high = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *start = calloc((size_t)(vertex_count + 1), sizeof(int64_t));
    int64_t *fill = malloc((size_t)(vertex_count + 1) * sizeof(int64_t));
    int64_t *bucket_high = NULL, *by_high = NULL, *spare = NULL, *bucket = NULL;
    int status = -1;
    if (low == NULL || high == NULL || start == NULL || fill == NULL) goto done;
    for (int64_t s = 0; s < n; s++) {
        int64_t a = faces[s], b = faces[3 * (s / 3) + (s % 3 + 1) % 3];
        low[s] = k_imin(a, b);
        high[s] = k_imax(a, b);
        start[low[s] + 1] += 1;
    }
    for (int64_t v = 0; v < vertex_count; v++) start[v + 1] += start[v];
    for (int64_t v = 0; v < vertex_count; v++) fill[v] = start[v];
    for (int64_t s = 0; s < n; s++) order[fill[low[s]]++] = s;
    for (int64_t v = 0; v < vertex_count; v++) {
        int64_t lo = start[v], hi = start[v + 1];
        if (hi - lo > 32) { /* a fan's apex: merge sort, not quadratic */
            if (bucket == NULL) { /* scratch for the largest bucket possible: n sides */
                bucket = malloc((size_t)n * sizeof(int64_t));
                bucket_high = malloc((size_t)n * sizeof(int64_t));
                by_high = malloc((size_t)n * sizeof(int64_t));
                spare = malloc((size_t)n * sizeof(int64_t));
                if (bucket == NULL || bucket_high == NULL || by_high == NULL || spare == NULL)
                    goto done;
            }
            for (int64_t i = 0; i < hi - lo; i++) {
                bucket[i] = order[lo + i];
                bucket_high[i] = high[bucket[i]];
            }
            const int64_t *sorted = stable_order(bucket_high, hi - lo, by_high, spare);
            for (int64_t i = 0; i < hi - lo; i++) order[lo + i] = bucket[sorted[i]];
            continue;
        }
        for (int64_t i = lo + 1; i < hi; i++) { /* insertion sort by high, stable */
            int64_t s = order[i], j = i;
            while (j > lo && high[order[j - 1]] > high[s]) {
                order[j] = order[j - 1];
                j--;
            }
            order[j] = s;
        }
    }
    for (int64_t i = 0; i < n; i++) keys[i] = low[order[i]] * vertex_count + high[order[i]];
    status = 0;
done:
    free(low);
    free(high);
    free(start);
    free(fill);
    free(bucket);
    free(bucket_high);
    free(by_high);
    free(spare);
    return status;
}

/* (keys, order) of the arguments (faces (m, 3) int64 with ids in [0, vertex_count),
 * vertex_count) of `kernel` as a new tuple, or NULL with a ValueError or MemoryError. */
static PyObject *sorted_sides(PyObject *args, const char *format, const char *kernel,
                             int64_t *vertex_count) {
    PyObject *result = NULL;
    PyArrayObject *keys = NULL, *order = NULL;
    PyArrayObject *faces = faces_argument(args, format, kernel, 0, vertex_count);
    if (faces == NULL) return NULL;
    npy_intp n = 3 * PyArray_DIM(faces, 0);
    keys = k_empty(1, &n, NPY_INT64);
    order = k_empty(1, &n, NPY_INT64);
    if (keys == NULL || order == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = key_order(K_I64(faces), n / 3, *vertex_count, K_I64(keys), K_I64(order));
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    result = PyTuple_Pack(2, (PyObject *)keys, (PyObject *)order);
done:
    Py_DECREF(faces);
    Py_XDECREF(keys);
    Py_XDECREF(order);
    return result;
}

/* key_order(faces (m, 3) int64, vertex_count) -> (keys (3m,) int64, order (3m,) int64). */
static PyObject *py_key_order(PyObject *self, PyObject *args) {
    int64_t vertex_count;
    return sorted_sides(args, "OL:key_order", "edge.key_order", &vertex_count);
}

/* counts(faces (m, 3) int64, vertex_count) -> (edges (e, 2) int64 ascending (low, high) pairs,
 * uses (e,) int64 the number of sides on each). */
static PyObject *py_counts(PyObject *self, PyObject *args) {
    int64_t vertex_count;
    PyObject *sides = sorted_sides(args, "OL:counts", "edge.counts", &vertex_count), *result = NULL;
    if (sides == NULL) return NULL;
    PyArrayObject *edges = NULL, *uses = NULL;
    const int64_t *keys = K_I64((PyArrayObject *)PyTuple_GET_ITEM(sides, 0));
    int64_t n = PyArray_DIM((PyArrayObject *)PyTuple_GET_ITEM(sides, 0), 0), distinct = 0;
    for (int64_t i = 0; i < n; i++) distinct += i == 0 || keys[i] != keys[i - 1];
    npy_intp dims[2] = {distinct, 2};
    edges = k_empty(2, dims, NPY_INT64);
    uses = k_zeros(1, dims, NPY_INT64);
    if (edges == NULL || uses == NULL) goto done;
    int64_t *e_out = K_I64(edges), *u_out = K_I64(uses);
    Py_BEGIN_ALLOW_THREADS
    int64_t e = -1;
    for (int64_t i = 0; i < n; i++) {
        if (i == 0 || keys[i] != keys[i - 1]) {
            e++;
            e_out[2 * e] = keys[i] / vertex_count;
            e_out[2 * e + 1] = keys[i] % vertex_count;
        }
        u_out[e] += 1;
    }
    Py_END_ALLOW_THREADS
    result = PyTuple_Pack(2, (PyObject *)edges, (PyObject *)uses);
done:
    Py_DECREF(sides);
    Py_XDECREF(edges);
    Py_XDECREF(uses);
    return result;
}

static PyMethodDef methods[] = {
    {"key_order", py_key_order, METH_VARARGS,
     "key_order(faces, vertex_count) -> (keys, order): sorted side keys and their stable order"},
    {"counts", py_counts, METH_VARARGS,
     "counts(faces, vertex_count) -> (edges, uses): distinct undirected edges and their uses"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(edge, "Face sides' undirected edge keys, sorted stably; distinct edges and their uses.",
         methods)
