/* Outline loops of many face regions at once (the walk of exporter.simplify.planar._region_loops).
 *
 * A region's outline is its half-edges whose reverse the region lacks; it is a set of closed loops
 * exactly when their sources are unique, their targets are unique and every target is a source.
 * Each loop is walked from its first outline half-edge in face order, skipping dropped vertices.
 * One region at a time, with per-vertex scratch arrays (the half-edges leaving a vertex as a
 * linked list): no sort. Data: directed half-edges (h, 2) int64 (vertex ids below k) of regions
 * (h,) ascending. Integers only: the former numpy and Python form (tests/test_outline_kernels.py
 * keeps it as the reference) is matched exactly.
 */
#include "kernels.h"
#include "sorted.h"

/* The walk over half (h, 2) of regions half_region (h,): fills bad (one per region), vertices,
 * bounds and loop_region (h, h + 1, h: upper bounds) and sets *count and *loops; returns -1
 * when scratch memory is lacking. */
static int walk(const int64_t *half, const int64_t *half_region, int64_t h, int64_t k,
                const npy_bool *droppable, npy_bool *bad, int64_t *vertices, int64_t *bounds,
                int64_t *loop_region, int64_t *count_out, int64_t *loops_out) {
    int64_t *head = malloc((size_t)(k + 1) * sizeof(int64_t));    /* a half-edge leaving v */
    int64_t *leaving = malloc((size_t)(k + 1) * sizeof(int64_t)); /* the outline one leaving v */
    npy_bool *entered = calloc((size_t)(k + 1), 1);               /* an outline one ends at v */
    int64_t *after = malloc((size_t)(h + 1) * sizeof(int64_t)); /* the next leaving the same v */
    int64_t *following = malloc((size_t)(h + 1) * sizeof(int64_t));
    npy_bool *outline = calloc((size_t)(h + 1), 1);
    npy_bool *seen = calloc((size_t)(h + 1), 1);
    int status = -1;
    if (head == NULL || leaving == NULL || entered == NULL || after == NULL ||
        following == NULL || outline == NULL || seen == NULL)
        goto done;
    for (int64_t v = 0; v < k; v++) head[v] = leaving[v] = -1;
    int64_t loops = 0, count = 0;
    bounds[0] = 0;
    for (int64_t lo = 0, hi; lo < h; lo = hi) {
        int64_t region = half_region[lo];
        hi = run_end(half_region, h, lo);
        for (int64_t e = lo; e < hi; e++) {
            after[e] = head[half[2 * e]];
            head[half[2 * e]] = e;
        }
        int broken = 0, found = 0;
        for (int64_t e = lo; e < hi; e++) {
            int64_t a = half[2 * e], b = half[2 * e + 1], f = head[b];
            while (f >= 0 && half[2 * f + 1] != a) f = after[f];
            if (f < 0) { /* no reverse in the region: an outline half-edge */
                outline[e] = 1;
                found = 1;
                broken |= leaving[a] >= 0 || entered[b];
                leaving[a] = e;
                entered[b] = 1;
            }
        }
        for (int64_t e = lo; e < hi; e++) {
            if (outline[e]) {
                following[e] = leaving[half[2 * e + 1]];
                broken |= following[e] < 0;
            }
        }
        broken |= !found;
        if (!broken) {
            for (int64_t first = lo; first < hi; first++) {
                if (!outline[first] || seen[first]) continue;
                for (int64_t e = first; !seen[e]; e = following[e]) {
                    seen[e] = 1;
                    int64_t v = half[2 * e];
                    if (!droppable[v]) vertices[count++] = v;
                }
                broken |= count - bounds[loops] < 3;
                loop_region[loops++] = region;
                bounds[loops] = count;
            }
        }
        bad[region] = (npy_bool)broken;
        for (int64_t e = lo; e < hi; e++) { /* clear the scratch for the next region */
            head[half[2 * e]] = -1;
            leaving[half[2 * e]] = -1;
            entered[half[2 * e + 1]] = 0;
        }
    }
    *count_out = count;
    *loops_out = loops;
    status = 0;
done:
    free(head);
    free(leaving);
    free(entered);
    free(after);
    free(following);
    free(outline);
    free(seen);
    return status;
}

/* loops(half (h, 2) int64, half_region (h,) int64 ascending, region_count, k, droppable (>= k,)
 * bool) -> (bad (region_count,) bool, vertices (h,), bounds (h + 1,), loop_region (h,), count,
 * loops): the first count vertices, loops + 1 bounds and loops regions hold the loops. */
static PyObject *loops(PyObject *self, PyObject *args) {
    PyObject *half_obj, *region_obj, *droppable_obj, *result = NULL;
    long long region_count, k;
    const char *kernel = "outline.loops";
    PyArrayObject *bad = NULL, *vertices = NULL, *bounds = NULL, *loop_region = NULL;
    if (!PyArg_ParseTuple(args, "OOLLO:loops", &half_obj, &region_obj, &region_count, &k,
                          &droppable_obj))
        return NULL;
    PyArrayObject *half = k_array(half_obj, NPY_INT64, 2, 0, kernel, "half");
    PyArrayObject *half_region = k_array(region_obj, NPY_INT64, 1, 0, kernel, "half_region");
    PyArrayObject *droppable = k_array(droppable_obj, NPY_BOOL, 1, 0, kernel, "droppable");
    if (half == NULL || half_region == NULL || droppable == NULL) goto done;
    npy_intp h = PyArray_DIM(half, 0), h1 = h + 1, dims[1] = {region_count};
    if (region_count < 0 || k < 0 || PyArray_DIM(droppable, 0) < k) {
        PyErr_Format(PyExc_ValueError, "%s: region_count %lld, k %lld, droppable (%zd,)", kernel,
                     region_count, k, (Py_ssize_t)PyArray_DIM(droppable, 0));
        goto done;
    }
    if (k_dim(half, 1, 2, kernel, "half") || k_indices(half, k, kernel, "half") ||
        k_dim(half_region, 0, h, kernel, "half_region") ||
        k_indices(half_region, region_count, kernel, "half_region"))
        goto done;
    bad = k_empty(1, dims, NPY_BOOL);
    vertices = k_empty(1, &h, NPY_INT64);
    bounds = k_empty(1, &h1, NPY_INT64);
    loop_region = k_empty(1, &h, NPY_INT64);
    if (bad == NULL || vertices == NULL || bounds == NULL || loop_region == NULL) goto done;
    int64_t count = 0, loops = 0;
    int status;
    Py_BEGIN_ALLOW_THREADS
    memset(K_BOOL(bad), 1, (size_t)region_count); /* a region without half-edges is bad */
    status = walk(K_I64(half), K_I64(half_region), h, k, K_BOOL(droppable), K_BOOL(bad),
                  K_I64(vertices), K_I64(bounds), K_I64(loop_region), &count, &loops);
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    result = Py_BuildValue("(OOOOLL)", bad, vertices, bounds, loop_region, (long long)count,
                           (long long)loops);
done:
    Py_XDECREF(half);
    Py_XDECREF(half_region);
    Py_XDECREF(droppable);
    Py_XDECREF(bad);
    Py_XDECREF(vertices);
    Py_XDECREF(bounds);
    Py_XDECREF(loop_region);
    return result;
}

static PyMethodDef methods[] = {
    {"loops", loops, METH_VARARGS,
     "loops(half, half_region, region_count, k, droppable) -> (bad, vertices, bounds, "
     "loop_region, count, loops): the outline loops of every region"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(outline, "Outline loops of many face regions at once (planar._region_loops' walk).",
         methods)
