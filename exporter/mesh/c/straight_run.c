/* Straight boundary runs merged into one segment (step 2 of exporter.mesh.hausdorff: a region's
 * projected outline).
 *
 * A run a -> b -> ... -> c of a region's boundary segments, through vertices with exactly one
 * oriented boundary segment in and one out, becomes the one segment ac when its inner vertices
 * lie within t_junction x |ac| of the chord ac on the region's side (left of a -> c; 1e-9 x |ac|
 * the other way for rounding); the largest offset goes into the region's gap. Runs start at
 * segments whose first vertex no run passes through, then the rest in order; segments of faces
 * that flip when projected stay as they are.
 *
 * The order of the walk and every float operation are those of the former Python loop
 * (tests/test_perf_hausdorff.py keeps it as the reference; the chord length is pow(., half) with
 * a run-time 0.5, as Python's ** 0.5, which is not always sqrt's bits), so the segments and gaps
 * are the same bits. Data form: segments seg (n, 2, 2) in-plane metres of regions region (n,);
 * (region, vertex) keys of each segment's start and end; the oriented segments in order of their
 * start keys (order_out) and their end keys sorted (keys_in).
 */
#include "kernels.h"
#include "sorted.h"

#define KERNEL "straight_run.runs"

/* The one oriented segment leaving `key` = (region, vertex) when exactly one leaves and one
 * enters it, else -1. keys_out (q,) and keys_in (q,) sorted; order_out (q,) the segment of each
 * keys_out. */
static int64_t through(const int64_t *keys_out, const int64_t *order_out, const int64_t *keys_in,
                       int64_t q, int64_t key) {
    int64_t s = lower_bound(keys_out, 0, q, key);
    if (upper_bound(keys_out, s, q, key) - s != 1) return -1;
    int64_t t = lower_bound(keys_in, 0, q, key);
    if (upper_bound(keys_in, t, q, key) - t != 1) return -1;
    return order_out[s];
}

/* The inputs of one walk and its scratch. */
typedef struct {
    int64_t n, q;
    const int64_t *region, *start_key, *end_key, *order_out, *keys_in;
    const double *seg; /* (n, 2, 2) */
    const npy_bool *oriented;
    double t_junction, half;
    int64_t *keys_out, *order; /* (q,), (n,) */
    npy_bool *used;            /* (n,) */
    double *inner_x, *inner_y; /* (n,) */
} Walk;

/* The walk: merged segments into out_region (n,), out_seg (n, 2, 2); gap (r,) raised; returns
 * the count written. */
static int64_t runs(const Walk *w, double *gap, int64_t *out_region, double *out_seg) {
    const double *seg = w->seg;
    int64_t n = w->n, first = 0, rest = 0;
    for (int64_t c = 0; c < w->q; c++) w->keys_out[c] = w->start_key[w->order_out[c]];
    /* Run starts first (no run passes through their first vertex), then the rest, in order:
     * the rest go to the end of `order` first, and are then put back in their order. */
    for (int64_t i = 0; i < n; i++) {
        if (through(w->keys_out, w->order_out, w->keys_in, w->q, w->start_key[i]) >= 0)
            w->order[n - 1 - rest++] = i;
        else
            w->order[first++] = i;
    }
    for (int64_t a = first, b = n - 1; a < b; a++, b--) {
        int64_t swap = w->order[a];
        w->order[a] = w->order[b];
        w->order[b] = swap;
    }
    memset(w->used, 0, (size_t)n * sizeof(npy_bool));
    int64_t count = 0;
    for (int64_t o = 0; o < n; o++) {
        int64_t i = w->order[o];
        if (w->used[i]) continue;
        w->used[i] = 1;
        int64_t g = w->region[i];
        if (!w->oriented[i]) {
            out_region[count] = g;
            memcpy(out_seg + 4 * count, seg + 4 * i, 4 * sizeof(double));
            count++;
            continue;
        }
        double sx = seg[4 * i], sy = seg[4 * i + 1];
        double ex = seg[4 * i + 2], ey = seg[4 * i + 3];
        int64_t inner = 0, j = i;
        for (;;) {
            int64_t nxt = through(w->keys_out, w->order_out, w->keys_in, w->q, w->end_key[j]);
            if (nxt < 0 || w->used[nxt]) break;
            double cx = seg[4 * nxt + 2] - sx, cy = seg[4 * nxt + 3] - sy;
            double length = pow(cx * cx + cy * cy, w->half);
            double high = -INFINITY, low = INFINITY;
            for (int64_t m = 0; m <= inner; m++) {
                double qx = ex, qy = ey;
                if (m < inner) {
                    qx = w->inner_x[m];
                    qy = w->inner_y[m];
                }
                double offset = length > 0 ? (cx * (qy - sy) - cy * (qx - sx)) / length : 1e300;
                high = k_max(high, offset);
                low = k_min(low, offset);
            }
            if (high > w->t_junction * length || low < -1e-9 * length) break;
            w->inner_x[inner] = ex;
            w->inner_y[inner] = ey;
            inner++;
            ex = seg[4 * nxt + 2];
            ey = seg[4 * nxt + 3];
            w->used[nxt] = 1;
            j = nxt;
        }
        if (inner) {
            double cx = ex - sx, cy = ey - sy;
            double length = pow(cx * cx + cy * cy, w->half);
            double widest = -INFINITY;
            for (int64_t m = 0; m < inner; m++)
                widest = k_max(widest,
                               fabs(cx * (w->inner_y[m] - sy) - cy * (w->inner_x[m] - sx)) / length);
            gap[g] = k_max(gap[g], widest);
        }
        out_region[count] = g;
        out_seg[4 * count] = sx;
        out_seg[4 * count + 1] = sy;
        out_seg[4 * count + 2] = ex;
        out_seg[4 * count + 3] = ey;
        count++;
    }
    return count;
}

/* runs(region (n,), seg (n, 2, 2), start_key (n,), end_key (n,), order_out (q,), keys_in (q,),
 * oriented (n,), t_junction, half, gap (r,), out_region (n,), out_seg (n, 2, 2)) -> count: the
 * merged segments are out_region[:count], out_seg[:count]; gap raised in place. */
static PyObject *runs_entry(PyObject *self, PyObject *args) {
    PyObject *region_obj, *seg_obj, *start_obj, *end_obj, *order_obj, *keys_in_obj, *oriented_obj;
    PyObject *gap_obj, *out_region_obj, *out_seg_obj, *result = NULL;
    double t_junction, half;
    void *scratch = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOOddOOO:runs", &region_obj, &seg_obj, &start_obj, &end_obj,
                          &order_obj, &keys_in_obj, &oriented_obj, &t_junction, &half, &gap_obj,
                          &out_region_obj, &out_seg_obj))
        return NULL;
    PyArrayObject *region = k_array(region_obj, NPY_INT64, 1, 0, KERNEL, "region");
    PyArrayObject *seg = k_array(seg_obj, NPY_FLOAT64, 3, 0, KERNEL, "seg");
    PyArrayObject *start = k_array(start_obj, NPY_INT64, 1, 0, KERNEL, "start_key");
    PyArrayObject *end = k_array(end_obj, NPY_INT64, 1, 0, KERNEL, "end_key");
    PyArrayObject *order = k_array(order_obj, NPY_INT64, 1, 0, KERNEL, "order_out");
    PyArrayObject *keys_in = k_array(keys_in_obj, NPY_INT64, 1, 0, KERNEL, "keys_in");
    PyArrayObject *oriented = k_array(oriented_obj, NPY_BOOL, 1, 0, KERNEL, "oriented");
    PyArrayObject *gap = k_array(gap_obj, NPY_FLOAT64, 1, 1, KERNEL, "gap");
    PyArrayObject *out_region = k_array(out_region_obj, NPY_INT64, 1, 1, KERNEL, "out_region");
    PyArrayObject *out_seg = k_array(out_seg_obj, NPY_FLOAT64, 3, 1, KERNEL, "out_seg");
    if (PyErr_Occurred()) goto done;
    npy_intp n = PyArray_DIM(region, 0), q = PyArray_DIM(order, 0);
    if (k_dim(seg, 0, n, KERNEL, "seg") || k_dim(seg, 1, 2, KERNEL, "seg") ||
        k_dim(seg, 2, 2, KERNEL, "seg") || k_dim(start, 0, n, KERNEL, "start_key") ||
        k_dim(end, 0, n, KERNEL, "end_key") || k_dim(keys_in, 0, q, KERNEL, "keys_in") ||
        k_dim(oriented, 0, n, KERNEL, "oriented") || k_dim(out_region, 0, n, KERNEL, "out_region") ||
        k_dim(out_seg, 0, n, KERNEL, "out_seg") || k_dim(out_seg, 1, 2, KERNEL, "out_seg") ||
        k_dim(out_seg, 2, 2, KERNEL, "out_seg") || k_indices(order, n, KERNEL, "order_out") ||
        k_indices(region, PyArray_DIM(gap, 0), KERNEL, "region"))
        goto done;
    /* keys_out (q), order (n), inner_x, inner_y (n each), used (n) */
    scratch = malloc(sizeof(int64_t) * (size_t)(q + n) + sizeof(double) * (size_t)(2 * n) +
                     sizeof(npy_bool) * (size_t)n + 1);
    if (scratch == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *inner_x = (double *)scratch, *inner_y = inner_x + n;
    int64_t *keys_out = (int64_t *)(inner_y + n), *walk_order = keys_out + q;
    Walk w = {n,           q,
              K_I64(region), K_I64(start), K_I64(end), K_I64(order), K_I64(keys_in),
              K_F64(seg),  K_BOOL(oriented),
              t_junction,  half,
              keys_out,    walk_order,
              (npy_bool *)(walk_order + n),
              inner_x,     inner_y};
    int64_t count;
    Py_BEGIN_ALLOW_THREADS
    count = runs(&w, K_F64(gap), K_I64(out_region), K_F64(out_seg));
    Py_END_ALLOW_THREADS
    result = PyLong_FromLongLong((long long)count);
done:
    free(scratch);
    Py_XDECREF(region);
    Py_XDECREF(seg);
    Py_XDECREF(start);
    Py_XDECREF(end);
    Py_XDECREF(order);
    Py_XDECREF(keys_in);
    Py_XDECREF(oriented);
    Py_XDECREF(gap);
    Py_XDECREF(out_region);
    Py_XDECREF(out_seg);
    return result;
}

static PyMethodDef methods[] = {
    {"runs", runs_entry, METH_VARARGS,
     "runs(region, seg, start_key, end_key, order_out, keys_in, oriented, t_junction, half, gap, "
     "out_region, out_seg) -> count: straight boundary runs merged, in-plane metres"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(straight_run, "Straight boundary runs of a region outline merged into one segment.",
         methods)
