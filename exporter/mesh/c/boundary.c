/* The open boundary of a triangle mesh: the face sides whose undirected edge no other side uses,
 * those edges as (low, high) vertex pairs, ascending, and the number of loops they form
 * (connected components of those edges; only vertices on an edge count).
 *
 * Side 3 f + i of faces (m, 3) int64 runs from corner i of face f to corner i + 1. Sides are
 * matched through per-vertex lists (the sides whose lower end is that vertex), so only the few
 * border keys are sorted (stable merge sort, sorted.h); loops are counted by union-find
 * (union_find.h). Integers only: the former numpy form (tests/test_boundary_kernels.py keeps it as
 * the reference) is matched exactly.
 */
#include "faces.h"
#include "kernels.h"
#include "sorted.h"
#include "union_find.h"

/* Writes to sides (3m) the sides of faces (m, 3) (ids in [0, vertex_count]) whose undirected edge
 * no other side uses, ascending; returns their count, or -1 when scratch memory is lacking. */
static int64_t once_sides(const int64_t *faces, int64_t m, int64_t vertex_count, int64_t *sides) {
    int64_t n = 3 * m, count = -1;
    int64_t *low = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *high = malloc((size_t)(n + 1) * sizeof(int64_t));
    int64_t *after = malloc((size_t)(n + 1) * sizeof(int64_t)); /* next side, same lower end */
    int64_t *head = malloc((size_t)(vertex_count + 1) * sizeof(int64_t)); /* a side per lower end */
    if (low == NULL || high == NULL || after == NULL || head == NULL) goto done;
    for (int64_t v = 0; v <= vertex_count; v++) head[v] = -1;
    for (int64_t s = 0; s < n; s++) {
        int64_t a = faces[s], b = faces[3 * (s / 3) + (s % 3 + 1) % 3];
        low[s] = k_imin(a, b);
        high[s] = k_imax(a, b);
        after[s] = head[low[s]];
        head[low[s]] = s;
    }
    count = 0;
    for (int64_t s = 0; s < n; s++) {
        int64_t uses = 0;
        for (int64_t r = head[low[s]]; r >= 0; r = after[r]) uses += high[r] == high[s];
        if (uses == 1) sides[count++] = s;
    }
done:
    free(low);
    free(high);
    free(after);
    free(head);
    return count;
}

/* The border sides of the arguments (faces, vertex_count) of `kernel`, parsed with `format`:
 * *faces (new reference), *vertex_count, *count and the malloc'd sides (3m + 1) the caller frees;
 * -1 with an exception set otherwise. */
static int border(PyObject *args, const char *format, const char *kernel, PyArrayObject **faces,
                  int64_t *vertex_count, int64_t **sides, int64_t *count) {
    *faces = faces_argument(args, format, kernel, 1, vertex_count);
    if (*faces == NULL) return -1;
    int64_t m = PyArray_DIM(*faces, 0);
    Py_BEGIN_ALLOW_THREADS
    *sides = malloc((size_t)(3 * m + 1) * sizeof(int64_t));
    *count = *sides == NULL ? -1 : once_sides(K_I64(*faces), m, *vertex_count, *sides);
    Py_END_ALLOW_THREADS
    if (*count >= 0) return 0;
    PyErr_NoMemory();
    free(*sides);
    *sides = NULL;
    Py_CLEAR(*faces);
    return -1;
}

/* once_sides(faces (m, 3) int64, vertex_count) -> (s,) int64 ascending: the sides whose
 * undirected edge no other side uses (ids in [0, vertex_count]). */
static PyObject *py_once_sides(PyObject *self, PyObject *args) {
    PyArrayObject *faces;
    int64_t vertex_count, *sides, count;
    if (border(args, "OL:once_sides", "boundary.once_sides", &faces, &vertex_count, &sides, &count))
        return NULL;
    npy_intp dims[1] = {count};
    PyArrayObject *result = k_empty(1, dims, NPY_INT64);
    if (result != NULL) memcpy(K_I64(result), sides, (size_t)count * sizeof(int64_t));
    free(sides);
    Py_DECREF(faces);
    return (PyObject *)result;
}

/* border_loops(faces (m, 3) int64, vertex_count) -> (edges (e, 2) int64, loops): the border
 * edges as ascending (low, high) pairs and the number of their connected components. */
static PyObject *py_border_loops(PyObject *self, PyObject *args) {
    PyArrayObject *faces, *edges = NULL;
    PyObject *result = NULL;
    int64_t vertex_count, *sides, count, loops = 0;
    if (border(args, "OL:border_loops", "boundary.border_loops", &faces, &vertex_count, &sides,
               &count))
        return NULL;
    int64_t base = vertex_count + 1;
    int64_t *keys = malloc((size_t)(count + 1) * sizeof(int64_t));
    int64_t *order = malloc((size_t)(count + 1) * sizeof(int64_t));
    int64_t *spare = malloc((size_t)(count + 1) * sizeof(int64_t));
    int64_t *parent = malloc((size_t)base * sizeof(int64_t));
    npy_intp dims[2] = {count, 2};
    if (keys == NULL || order == NULL || spare == NULL || parent == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    edges = k_empty(2, dims, NPY_INT64);
    if (edges == NULL) goto done;
    const int64_t *f = K_I64(faces);
    int64_t *out = K_I64(edges);
    Py_BEGIN_ALLOW_THREADS
    for (int64_t e = 0; e < count; e++) {
        int64_t s = sides[e];
        int64_t a = f[s], b = f[3 * (s / 3) + (s % 3 + 1) % 3];
        keys[e] = k_imin(a, b) * base + k_imax(a, b);
    }
    const int64_t *sorted = stable_order(keys, count, order, spare);
    for (int64_t v = 0; v < base; v++) parent[v] = -1;
    for (int64_t e = 0; e < count; e++) {
        int64_t key = keys[sorted[e]];
        int64_t ends[2] = {key / base, key % base};
        out[2 * e] = ends[0];
        out[2 * e + 1] = ends[1];
        for (int i = 0; i < 2; i++) {
            if (parent[ends[i]] < 0) {
                parent[ends[i]] = ends[i];
                loops++;
            }
        }
        int64_t ra = uf_root(parent, ends[0]), rb = uf_root(parent, ends[1]);
        if (ra != rb) {
            parent[ra] = rb;
            loops--;
        }
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("(OL)", (PyObject *)edges, (long long)loops);
done:
    free(sides);
    free(keys);
    free(order);
    free(spare);
    free(parent);
    Py_DECREF(faces);
    Py_XDECREF(edges);
    return result;
}

static PyMethodDef methods[] = {
    {"once_sides", py_once_sides, METH_VARARGS,
     "once_sides(faces, vertex_count) -> sides: the sides no other side shares an edge with"},
    {"border_loops", py_border_loops, METH_VARARGS,
     "border_loops(faces, vertex_count) -> (edges, loops): border edges and their loop count"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(boundary, "The open boundary of a triangle mesh: border sides, edges and loops.", methods)
