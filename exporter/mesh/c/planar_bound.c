/* The in-plane bound of the certified Hausdorff distance (step 2 of exporter.mesh.hausdorff,
 * which holds the argument; this is its arithmetic).
 *
 * For each (triangle, candidate face) pair: the face's planar region (flat within
 * plane_slack_max), the triangle's corners in the region's plane axes and their largest height
 * over its plane; the pair counts when the centroid's projection lies in the face (1e-9 relative
 * margin) and, with a cap, the plane bound stays under it; each (triangle, region) is bounded
 * once, by its first pair. A triangle shrunk about its incentre by `shrink` that no boundary
 * segment of the region crosses (separating axes: Ericson, "Real-Time Collision Detection"
 * (2005), 5.2.1) lies in the region: bound sqrt(h^2 + rho^2) + slack, rho = 2 x ratio x its
 * reach + the region's gap. When segments cross it, each side is moved in just past the segments
 * charged to it (the side they enter least) and the moved triangle tested against every segment
 * of the region; then shrinks by shares `loose` of the target's diagonal, tested against the
 * segments that crossed the first copy.
 *
 * Every float operation is the former numpy form's, in its order (np.hypot is libm's hypot in
 * both, x ** 2 is x * x), so the bounds are the same bits (tests/test_perf_hausdorff.py).
 * Data form: triangles (n, 3, 3) metres in any one Cartesian frame; planes (12, r) rows slack,
 * offset, gap, u (3 rows), v (3 rows), normal (3 rows); faces projected tri2 (m, 3, 2) and the
 * regions' boundary segments seg (4, s) rows x0, y0, x1, y1 (CSR by seg_start (r + 1,)), in-plane
 * metres.
 */
#include "kernels.h"
#include "sorted.h"

#define KERNEL "planar_bound.bound"

/* The segment (x0, y0)-(x1, y1) meets the open triangle (px, py) (3,): bounding boxes, then
 * separating axes (the triangle's edge normals, then the segment's). */
static int crosses(const double *px, const double *py, double x0, double y0, double x1,
                   double y1) {
    double low_x = k_min(k_min(px[0], px[1]), px[2]), high_x = k_max(k_max(px[0], px[1]), px[2]);
    double low_y = k_min(k_min(py[0], py[1]), py[2]), high_y = k_max(k_max(py[0], py[1]), py[2]);
    if (!(k_max(x0, x1) > low_x && k_min(x0, x1) < high_x)) return 0;
    if (!(k_max(y0, y1) > low_y && k_min(y0, y1) < high_y)) return 0;
    for (int a = 0; a < 4; a++) {
        double nx, ny;
        if (a < 3) {
            nx = py[a] - py[(a + 1) % 3];
            ny = px[(a + 1) % 3] - px[a];
        } else {
            nx = y0 - y1;
            ny = x1 - x0;
        }
        double t0 = px[0] * nx + py[0] * ny;
        double t1 = px[1] * nx + py[1] * ny;
        double t2 = px[2] * nx + py[2] * ny;
        double s0 = x0 * nx + y0 * ny, s1 = x1 * nx + y1 * ny;
        if (k_max(s0, s1) <= k_min(k_min(t0, t1), t2) || k_min(s0, s1) >= k_max(k_max(t0, t1), t2))
            return 0;
    }
    return 1;
}

/* The segment s of seg (4, stride) meets the open triangle (px, py). */
static int crosses_segment(const double *px, const double *py, const double *seg,
                           int64_t stride, int64_t s) {
    return crosses(px, py, seg[s], seg[stride + s], seg[2 * stride + s], seg[3 * stride + s]);
}

/* (x, y) lies in the closed 2-D triangle tri2 (3, 2), with a 1e-9 relative margin. */
static int inside_face(double x, double y, const double *tri2) {
    int pos = 1, neg = 1;
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3;
        double ex = tri2[2 * j] - tri2[2 * i], ey = tri2[2 * j + 1] - tri2[2 * i + 1];
        double wx = x - tri2[2 * i], wy = y - tri2[2 * i + 1];
        double side = ex * wy - ey * wx;
        double margin = 1e-9 * (fabs(ex) + fabs(ey)) * (fabs(wx) + fabs(wy) + fabs(ex) + fabs(ey));
        pos &= side >= -margin;
        neg &= side <= margin;
    }
    return pos || neg;
}

/* np.sign of a float: a zero (of either sign) or a NaN is returned as it is. */
static double sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : x); }

/* Each side moved in past the `count` crossing segments charged to it; the moved corners in mx,
 * my; returns the largest corner move (metres), or -1 when a move reaches a quarter of the
 * inradius or is not finite. */
static double sides_in(const double *tx, const double *ty, double inradius,
                       const int64_t *crossing, int64_t count, const double *seg, int64_t stride,
                       double shrink, double *mx, double *my) {
    double nx[3], ny[3], need[3] = {0.0, 0.0, 0.0}, depth[3], delta[3];
    double orient = sign((tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]));
    for (int i = 0; i < 3; i++) {
        double ex = tx[(i + 1) % 3] - tx[i], ey = ty[(i + 1) % 3] - ty[i];
        double length = hypot(ex, ey);
        nx[i] = -ey / length * orient;
        ny[i] = ex / length * orient;
    }
    for (int64_t c = 0; c < count; c++) {
        int64_t s = crossing[c];
        double x0 = seg[s], y0 = seg[stride + s], x1 = seg[2 * stride + s], y1 = seg[3 * stride + s];
        for (int i = 0; i < 3; i++)
            depth[i] = k_max((x0 - tx[i]) * nx[i] + (y0 - ty[i]) * ny[i],
                             (x1 - tx[i]) * nx[i] + (y1 - ty[i]) * ny[i]);
        int side = 0;
        for (int i = 1; i < 3; i++)
            if (depth[i] < depth[side]) side = i;
        need[side] = k_max(need[side], depth[side]);
    }
    double size = k_max(k_max(fabs(tx[0]), fabs(tx[1])), fabs(tx[2])) +
                  k_max(k_max(fabs(ty[0]), fabs(ty[1])), fabs(ty[2]));
    for (int i = 0; i < 3; i++) {
        delta[i] = k_max(need[i] * (1 + 1e-6) + 1e-12 * size, shrink * inradius);
        if (!(delta[i] < 0.25 * inradius)) return -1.0;
    }
    double shift = -INFINITY;
    for (int i = 0; i < 3; i++) {
        int b = (i + 2) % 3; /* corner i lies on sides i - 1 and i */
        double c1 = nx[b] * tx[b] + ny[b] * ty[b] + delta[b];
        double c2 = nx[i] * tx[i] + ny[i] * ty[i] + delta[i];
        double det = nx[b] * ny[i] - ny[b] * nx[i];
        mx[i] = (c1 * ny[i] - ny[b] * c2) / det;
        my[i] = (nx[b] * c2 - c1 * nx[i]) / det;
        double dx = mx[i] - tx[i], dy = my[i] - ty[i];
        double d = sqrt(dx * dx + dy * dy);
        if (!isfinite(d)) return -1.0; /* NaN or inf (parallel sides): no move */
        shift = k_max(shift, d);
    }
    return shift;
}

/* What value() needs beyond one triangle: the segments, the constants and a scratch (s,). */
typedef struct {
    const double *seg; /* (4, stride) */
    int64_t stride;
    double scale, shrink;
    const double *loose;
    int64_t levels;
    int64_t *crossing;
} Context;

/* sqrt(h^2 + rho^2) + slack: the bound once the triangle is known to be in the region. */
static double plane_bound(double height, double rho, double slack) {
    return sqrt(height * height + rho * rho) + slack;
}

/* The in-plane bound (metres) of one triangle (tx, ty) (3,) in one region whose boundary
 * segments are seg[:, lo:hi], inf where none holds. */
static double value(const double *tx, const double *ty, double height, double slack,
                    double gap, int64_t lo, int64_t hi, const Context *k) {
    double la = hypot(tx[2] - tx[1], ty[2] - ty[1]); /* side opposite each corner */
    double lb = hypot(tx[0] - tx[2], ty[0] - ty[2]);
    double lc = hypot(tx[1] - tx[0], ty[1] - ty[0]);
    double perimeter = la + lb + lc;
    double area2 = fabs((tx[1] - tx[0]) * (ty[2] - ty[0]) - (ty[1] - ty[0]) * (tx[2] - tx[0]));
    double ix = (la * tx[0] + lb * tx[1] + lc * tx[2]) / perimeter;
    double iy = (la * ty[0] + lb * ty[1] + lc * ty[2]) / perimeter;
    double inradius = area2 / perimeter;
    double reach2 = -INFINITY;
    for (int c = 0; c < 3; c++) {
        double dx = tx[c] - ix, dy = ty[c] - iy;
        reach2 = k_max(reach2, dx * dx + dy * dy);
    }
    double reach = sqrt(reach2);
    double size = k_max(k_max(fabs(tx[0]), fabs(tx[1])), fabs(tx[2]));
    size = size + k_max(k_max(fabs(ty[0]), fabs(ty[1])), fabs(ty[2])) + reach;
    if (!(isfinite(inradius) && inradius > 1e-9 * size))
        return INFINITY; /* too thin to shrink safely against rounding */
    double sx[3], sy[3];
    for (int c = 0; c < 3; c++) {
        sx[c] = ix + (tx[c] - ix) * (1.0 - k->shrink);
        sy[c] = iy + (ty[c] - iy) * (1.0 - k->shrink);
    }
    int64_t count = 0;
    for (int64_t s = lo; s < hi; s++)
        if (crosses_segment(sx, sy, k->seg, k->stride, s)) k->crossing[count++] = s;
    if (count == 0) return plane_bound(height, 2.0 * k->shrink * reach + gap, slack);
    double shift =
        sides_in(tx, ty, inradius, k->crossing, count, k->seg, k->stride, k->shrink, sx, sy);
    if (shift >= 0) {
        int crossed = 0;
        for (int64_t s = lo; s < hi && !crossed; s++)
            crossed = crosses_segment(sx, sy, k->seg, k->stride, s);
        if (!crossed) return plane_bound(height, 2.0 * shift + gap, slack);
    }
    for (int64_t level = 0; level < k->levels; level++) {
        double delta = k_max(k->shrink * inradius, k->loose[level] * k->scale);
        if (!(delta < 0.5 * inradius)) continue;
        double ratio = delta / inradius;
        for (int c = 0; c < 3; c++) {
            sx[c] = ix + (tx[c] - ix) * (1.0 - ratio);
            sy[c] = iy + (ty[c] - iy) * (1.0 - ratio);
        }
        int inside = 1;
        for (int64_t c = 0; c < count && inside; c++)
            inside = !crosses_segment(sx, sy, k->seg, k->stride, k->crossing[c]);
        if (inside) return plane_bound(height, 2.0 * ratio * reach + gap, slack);
    }
    return INFINITY;
}

/* 0 when seg_start (r + 1,) starts at 0 or later, never decreases and ends by s, else -1 with a
 * ValueError. */
static int check_starts(const int64_t *start, npy_intp r, npy_intp s) {
    for (npy_intp g = 0; g <= r; g++) {
        if ((g == 0 && start[0] < 0) || (g > 0 && start[g] < start[g - 1]) || start[g] > s) {
            PyErr_SetString(PyExc_ValueError,
                            KERNEL ": seg_start must rise from 0 or more to the segment count");
            return -1;
        }
    }
    return 0;
}

/* bound(tri (n, 3, 3), row (p,), face (p,), region (m,), planes (12, r), tri2 (m, 3, 2),
 * seg_start (r + 1,), seg (4, s), cap (n,) or None, loose (l,), scale, shrink, plane_slack_max,
 * out (n,)): out[row] lowered to the in-plane bound of each kept (triangle, region) pair. */
static PyObject *bound(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *row_obj, *face_obj, *region_obj, *planes_obj, *tri2_obj, *start_obj;
    PyObject *seg_obj, *cap_obj, *loose_obj, *out_obj, *result = NULL;
    double scale, shrink, plane_slack_max;
    void *scratch = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOOOOOdddO:bound", &tri_obj, &row_obj, &face_obj,
                          &region_obj, &planes_obj, &tri2_obj, &start_obj, &seg_obj, &cap_obj,
                          &loose_obj, &scale, &shrink, &plane_slack_max, &out_obj))
        return NULL;
    int has_cap = cap_obj != Py_None;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, KERNEL, "tri");
    PyArrayObject *row = k_array(row_obj, NPY_INT64, 1, 0, KERNEL, "row");
    PyArrayObject *face = k_array(face_obj, NPY_INT64, 1, 0, KERNEL, "face");
    PyArrayObject *region = k_array(region_obj, NPY_INT64, 1, 0, KERNEL, "region");
    PyArrayObject *planes = k_array(planes_obj, NPY_FLOAT64, 2, 0, KERNEL, "planes");
    PyArrayObject *tri2 = k_array(tri2_obj, NPY_FLOAT64, 3, 0, KERNEL, "tri2");
    PyArrayObject *start = k_array(start_obj, NPY_INT64, 1, 0, KERNEL, "seg_start");
    PyArrayObject *seg = k_array(seg_obj, NPY_FLOAT64, 2, 0, KERNEL, "seg");
    PyArrayObject *cap = has_cap ? k_array(cap_obj, NPY_FLOAT64, 1, 0, KERNEL, "cap") : NULL;
    PyArrayObject *loose = k_array(loose_obj, NPY_FLOAT64, 1, 0, KERNEL, "loose");
    PyArrayObject *out = k_array(out_obj, NPY_FLOAT64, 1, 1, KERNEL, "out");
    if (PyErr_Occurred()) goto done;
    npy_intp n = PyArray_DIM(tri, 0), p = PyArray_DIM(row, 0), m = PyArray_DIM(region, 0);
    npy_intp r = PyArray_DIM(planes, 1), s = PyArray_DIM(seg, 1);
    if (k_dim(tri, 1, 3, KERNEL, "tri") || k_dim(tri, 2, 3, KERNEL, "tri") ||
        k_dim(face, 0, p, KERNEL, "face") || k_dim(planes, 0, 12, KERNEL, "planes") ||
        k_dim(tri2, 0, m, KERNEL, "tri2") || k_dim(tri2, 1, 3, KERNEL, "tri2") ||
        k_dim(tri2, 2, 2, KERNEL, "tri2") || k_dim(start, 0, r + 1, KERNEL, "seg_start") ||
        k_dim(seg, 0, 4, KERNEL, "seg") || (has_cap && k_dim(cap, 0, n, KERNEL, "cap")) ||
        k_dim(out, 0, n, KERNEL, "out") || k_indices(row, n, KERNEL, "row") ||
        k_indices(face, m, KERNEL, "face") || k_indices(region, r, KERNEL, "region") ||
        check_starts(K_I64(start), r, s))
        goto done;
    /* keys, kept, order, spare (p each), tx, ty (3p each), height (p), crossing (s) */
    scratch = malloc(sizeof(int64_t) * (size_t)(4 * p + s) + sizeof(double) * (size_t)(7 * p) + 1);
    if (scratch == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *t = K_F64(tri), *pl = K_F64(planes), *tr2 = K_F64(tri2);
    const double *cp = has_cap ? K_F64(cap) : NULL;
    const int64_t *rw = K_I64(row), *fc = K_I64(face), *region_of = K_I64(region);
    const int64_t *seg_start = K_I64(start);
    double *bnd = K_F64(out);
    double *tx = (double *)scratch, *ty = tx + 3 * p, *height = ty + 3 * p;
    int64_t *keys = (int64_t *)(height + p), *kept = keys + p, *order = kept + p;
    int64_t *spare = order + p;
    Context k = {K_F64(seg), s, scale, shrink, K_F64(loose), PyArray_DIM(loose, 0), spare + p};
    const double *slack = pl, *offset = pl + r, *gap = pl + 2 * r;
    const double *u = pl + 3 * r, *v = pl + 6 * r, *normal = pl + 9 * r;
    Py_BEGIN_ALLOW_THREADS
    int64_t count = 0;
    for (npy_intp i = 0; i < p; i++) {
        int64_t g = region_of[fc[i]];
        if (!(slack[g] <= plane_slack_max)) continue;
        const double *c = t + 9 * rw[i];
        double h = -INFINITY;
        for (int j = 0; j < 3; j++) {
            const double *q = c + 3 * j;
            tx[3 * i + j] = q[0] * u[g] + q[1] * u[r + g] + q[2] * u[2 * r + g];
            ty[3 * i + j] = q[0] * v[g] + q[1] * v[r + g] + q[2] * v[2 * r + g];
            double along = q[0] * normal[g] + q[1] * normal[r + g] + q[2] * normal[2 * r + g];
            h = k_max(h, fabs(along - offset[g]));
        }
        height[i] = h;
        double cx = (tx[3 * i] + tx[3 * i + 1] + tx[3 * i + 2]) / 3.0;
        double cy = (ty[3 * i] + ty[3 * i + 1] + ty[3 * i + 2]) / 3.0;
        int keep = inside_face(cx, cy, tr2 + 6 * fc[i]);
        if (has_cap) keep &= h + slack[g] < cp[rw[i]];
        if (keep) {
            keys[count] = rw[i] * (r + 1) + g;
            kept[count] = i;
            count++;
        }
    }
    int64_t *sorted = stable_order(keys, count, order, spare);
    for (int64_t j = 0; j < count; j++) {
        if (j > 0 && keys[sorted[j]] == keys[sorted[j - 1]])
            continue; /* one test per (triangle, region): its first pair */
        int64_t i = kept[sorted[j]];
        int64_t g = region_of[fc[i]];
        double b = value(tx + 3 * i, ty + 3 * i, height[i], slack[g], gap[g], seg_start[g],
                         seg_start[g + 1], &k);
        bnd[rw[i]] = k_min(bnd[rw[i]], b);
    }
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    free(scratch);
    Py_XDECREF(tri);
    Py_XDECREF(row);
    Py_XDECREF(face);
    Py_XDECREF(region);
    Py_XDECREF(planes);
    Py_XDECREF(tri2);
    Py_XDECREF(start);
    Py_XDECREF(seg);
    Py_XDECREF(cap);
    Py_XDECREF(loose);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"bound", bound, METH_VARARGS,
     "bound(tri, row, face, region, planes, tri2, seg_start, seg, cap, loose, scale, shrink, "
     "plane_slack_max, out): out lowered to each triangle's in-plane bound, metres"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(planar_bound, "The in-plane bound of the certified Hausdorff distance.", methods)
