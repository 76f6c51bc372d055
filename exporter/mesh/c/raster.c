/* Conservative rasterisation of triangles: one triangle, one pixel row at a time.
 *
 * Pixel (row r, column c) is the unit square centred on (c, r); a triangle covers every pixel of
 * every row r whose strip [r - 0.5, r + 0.5] it meets, from the column of the leftmost to that of
 * the rightmost point where its edges cross the strip (clipped to the raster). An edge's x on a
 * line y is px + (clip(y, py, qy) - py) * slope (p its lower end, q its upper end); a flat edge
 * gives its two end x. This is the arithmetic of the former vectorised numpy form, so the pixels
 * are the same bit for bit (tests/test_perf_quality.py checks them against a plain reference).
 * Pixel coordinates, any view. And the pixel counts of two stacks of views' intersections and
 * unions (their IoU).
 */
#include "kernels.h"

/* (int64_t)min(max(ceil(v), 0), top) for v not NaN, top >= 0 an integer, without the
 * libm-free ceil's instruction sequence: ceil(v) <= 0 exactly when v <= 0, ceil(v) > top
 * exactly when v > top, and ceil of v in (0, top] is its truncation, plus one unless whole. */
static inline int64_t ceil_clip(double v, int64_t top) {
    if (!(v > 0)) return 0;
    if (v > (double)top) return top;
    int64_t t = (int64_t)v;
    return t + ((double)t < v);
}

/* (int64_t)min(max(floor(w), 0), top) likewise: floor(w) <= 0 exactly when w < 1, floor(w) >
 * top exactly when w >= top + 1, and floor of w in [1, top + 1) is its truncation. */
static inline int64_t floor_clip(double w, int64_t top) {
    if (!(w >= 1)) return 0;
    if (w >= (double)top + 1) return top;
    return (int64_t)w;
}

/* Spans of one view: +1 at a span's first column, -1 past its last, summed per row at the end,
 * so each triangle costs its rows, not its pixels. spans is (size, size + 1). */
static void view_spans(const double *xy, const int64_t *faces, npy_intp m, int64_t size,
                       int32_t *spans) {
    int64_t top = size - 1;
    double px[3], py[3], qx[3], qy[3], slope[3];
    for (npy_intp f = 0; f < m; f++) {
        double y_min = INFINITY, y_max = -INFINITY;
        for (int k = 0; k < 3; k++) {
            const double *a = xy + 2 * faces[3 * f + k], *b = xy + 2 * faces[3 * f + (k + 1) % 3];
            double x0 = a[0], y0 = a[1], x1 = b[0], y1 = b[1];
            y_min = k_min(y_min, y0);
            y_max = k_max(y_max, y0);
            if (y0 > y1) { /* p the lower end, q the upper end */
                px[k] = x1; py[k] = y1; qx[k] = x0; qy[k] = y0;
            } else {
                px[k] = x0; py[k] = y0; qx[k] = x1; qy[k] = y1;
            }
            double dy = qy[k] - py[k];
            slope[k] = dy > 0 ? (qx[k] - px[k]) / dy : 0.0;
        }
        if (isnan(y_min) || isnan(y_max)) continue; /* no row: a NaN corner covers nothing */
        int64_t r0 = ceil_clip(y_min - 0.5, top);
        int64_t r1 = floor_clip(y_max + 0.5, top);
        for (int64_t r = r0; r <= r1; r++) {
            double bottom = (double)r - 0.5, upper = (double)r + 0.5;
            double lo = INFINITY, hi = -INFINITY;
            for (int k = 0; k < 3; k++) {
                if (!(py[k] <= upper && qy[k] >= bottom)) continue;
                double at = px[k] + (k_min(k_max(bottom, py[k]), qy[k]) - py[k]) * slope[k];
                double at_top;
                if (qy[k] - py[k] > 0)
                    at_top = px[k] + (k_min(k_max(upper, py[k]), qy[k]) - py[k]) * slope[k];
                else
                    at_top = qx[k];
                lo = k_min(lo, k_min(at, at_top));
                hi = k_max(hi, k_max(at, at_top));
            }
            if (lo <= hi) {
                int64_t c0 = ceil_clip(lo - 0.5, top);
                int64_t c1 = floor_clip(hi + 0.5, top);
                spans[r * (size + 1) + c0] += 1;
                spans[r * (size + 1) + c1 + 1] -= 1;
            }
        }
    }
}

/* rasterise(xy (v, n, 2) float64, faces (m, 3) int64, size, out (v, size, size) bool): out set to
 * each view's conservative coverage. The caller checks the face indices. */
static PyObject *rasterise(PyObject *self, PyObject *args) {
    PyObject *xy_obj, *faces_obj, *out_obj, *result = NULL;
    Py_ssize_t size;
    int32_t *spans = NULL;
    if (!PyArg_ParseTuple(args, "OOnO:rasterise", &xy_obj, &faces_obj, &size, &out_obj))
        return NULL;
    PyArrayObject *xy = k_array(xy_obj, NPY_FLOAT64, 3, 0, "raster.rasterise", "xy");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, "raster.rasterise", "faces");
    PyArrayObject *out = k_array(out_obj, NPY_BOOL, 3, 1, "raster.rasterise", "out");
    if (xy == NULL || faces == NULL || out == NULL) goto done;
    npy_intp views = PyArray_DIM(xy, 0), n = PyArray_DIM(xy, 1), m = PyArray_DIM(faces, 0);
    if (size < 1) {
        PyErr_SetString(PyExc_ValueError, "raster.rasterise: size must be >= 1");
        goto done;
    }
    if (k_dim(xy, 2, 2, "raster.rasterise", "xy") || k_dim(faces, 1, 3, "raster.rasterise", "faces") ||
        k_dim(out, 0, views, "raster.rasterise", "out") || k_dim(out, 1, size, "raster.rasterise", "out") ||
        k_dim(out, 2, size, "raster.rasterise", "out") || k_indices(faces, n, "raster.rasterise", "faces"))
        goto done;
    spans = malloc(sizeof(int32_t) * (size_t)size * (size_t)(size + 1));
    if (spans == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *xyp = K_F64(xy);
    const int64_t *f = K_I64(faces);
    npy_bool *o = K_BOOL(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp view = 0; view < views; view++) {
        memset(spans, 0, sizeof(int32_t) * (size_t)size * (size_t)(size + 1));
        view_spans(xyp + view * n * 2, f, m, size, spans);
        npy_bool *plane = o + view * size * size;
        for (npy_intp r = 0; r < size; r++) {
            /* The running sum in place, then the coverage test (a loop the compiler vectorises). */
            int32_t *row = spans + r * (size + 1);
            int32_t total = 0;
            for (npy_intp c = 0; c < size; c++) {
                total += row[c];
                row[c] = total;
            }
            for (npy_intp c = 0; c < size; c++) plane[r * size + c] = row[c] > 0;
        }
    }
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    free(spans);
    Py_XDECREF(xy);
    Py_XDECREF(faces);
    Py_XDECREF(out);
    return result;
}

/* overlaps(a (v, n, n) bool, b (v, n, n) bool) -> (v, 2) int64: per view, the pixels set in
 * both and the pixels set in either. */
static PyObject *overlaps(PyObject *self, PyObject *args) {
    PyObject *a_obj, *b_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OO:overlaps", &a_obj, &b_obj)) return NULL;
    PyArrayObject *a = k_array(a_obj, NPY_BOOL, 3, 0, "raster.overlaps", "a");
    PyArrayObject *b = k_array(b_obj, NPY_BOOL, 3, 0, "raster.overlaps", "b");
    PyArrayObject *out = NULL;
    if (a == NULL || b == NULL) goto done;
    for (int axis = 0; axis < 3; axis++)
        if (k_dim(b, axis, PyArray_DIM(a, axis), "raster.overlaps", "b")) goto done;
    npy_intp views = PyArray_DIM(a, 0), pixels = PyArray_DIM(a, 1) * PyArray_DIM(a, 2);
    npy_intp dims[2] = {views, 2};
    out = k_empty(2, dims, NPY_INT64);
    if (out == NULL) goto done;
    const npy_bool *p = K_BOOL(a), *q = K_BOOL(b);
    int64_t *o = K_I64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp view = 0; view < views; view++) {
        int64_t both = 0, either = 0;
        for (npy_intp i = view * pixels; i < (view + 1) * pixels; i++) {
            both += (p[i] != 0) & (q[i] != 0);
            either += (p[i] != 0) | (q[i] != 0);
        }
        o[2 * view] = both;
        o[2 * view + 1] = either;
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(a);
    Py_XDECREF(b);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"rasterise", rasterise, METH_VARARGS,
     "rasterise(xy, faces, size, out): each view's conservative coverage of the triangles"},
    {"overlaps", overlaps, METH_VARARGS,
     "overlaps(a, b) -> (v, 2) int64: per view, the pixels set in both and in either"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(raster, "Conservative rasterisation of triangles, one pixel row at a time.", methods)
