/* Point-to-surface queries of the certified Hausdorff bound, one point at a time.
 *
 * upper: a point's upper bound from the triangles owning its nearest probes (the k-d tree query
 *   stays in scipy): 0 for a point on a probe, else the least exact distance to those triangles
 *   (exporter/mesh/distance.py, SurfaceIndex._upper; a NaN distance gives NaN, as np.minimum).
 * nearest_face: a face at the least distance from each point among the faces whose bounding
 *   sphere and plane both come within the point's reach (exporter/mesh/hausdorff.py,
 *   _nearest_face): the first such face in face order with the least distance, NaN distances
 *   last (as np.lexsort), face 0 when none qualifies.
 * single_bound, chain_bound: a triangle's bound from one face (step 1 of the module doc of
 *   hausdorff.py, _single_triangle_bound) or one straight edge chain (_chain_bound): the least
 *   over its candidates of the largest distance of its corners.
 * pair_bound: a triangle's bound over two cells cut where two faces' planes are equally far
 *   (step 1b, _pair_bound).
 * split4: the refinement's split of each triangle in four (hausdorff.split4).
 * centres_radii, planes, project: a surface's preparation (SurfaceIndex's centres and radii,
 *   hausdorff._planes, _Regions.tri2), the numpy forms' sums in numpy's order
 *   (tests/test_surface_prep.py keeps the forms and checks the bits).
 *
 * Data form: points (p, 3), triangles (m, 3, 3) corner after corner, in any one Cartesian frame,
 * metres. Each float expression keeps the order of the numpy form it replaces, so the results are
 * the same bits (tests/test_surface_kernels.py); distances are Ericson's (point_triangle.h).
 */
#include "point_triangle.h"


/* upper(points (p, 3), probe_distance (p, k), nearest (p, k) int64 probe ids, owner (n,) int64
 * the triangle of each probe, tri (m, 3, 3)) -> (p,) float64 metres. */
static PyObject *upper(PyObject *self, PyObject *args) {
    PyObject *points_obj, *probe_obj, *nearest_obj, *owner_obj, *tri_obj, *result = NULL;
    const char *kernel = "surface.upper";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOO:upper", &points_obj, &probe_obj, &nearest_obj, &owner_obj,
                          &tri_obj))
        return NULL;
    PyArrayObject *points = k_array(points_obj, NPY_FLOAT64, 2, 0, kernel, "points");
    PyArrayObject *probe = k_array(probe_obj, NPY_FLOAT64, 2, 0, kernel, "probe_distance");
    PyArrayObject *nearest = k_array(nearest_obj, NPY_INT64, 2, 0, kernel, "nearest");
    PyArrayObject *owner = k_array(owner_obj, NPY_INT64, 1, 0, kernel, "owner");
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    if (points == NULL || probe == NULL || nearest == NULL || owner == NULL || tri == NULL) goto done;
    npy_intp p = PyArray_DIM(points, 0), k = PyArray_DIM(probe, 1), m = PyArray_DIM(tri, 0);
    if (k_dim(points, 1, 3, kernel, "points") || k_dim(probe, 0, p, kernel, "probe_distance") ||
        k_dim(nearest, 0, p, kernel, "nearest") || k_dim(nearest, 1, k, kernel, "nearest") ||
        k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri") ||
        k_indices(nearest, PyArray_DIM(owner, 0), kernel, "nearest") ||
        k_indices(owner, m, kernel, "owner"))
        goto done;
    if (k < 1 && p > 0) {
        PyErr_Format(PyExc_ValueError, "%s: probe_distance needs one probe per point", kernel);
        goto done;
    }
    npy_intp dims[1] = {p};
    out = k_empty(1, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *pt = K_F64(points), *pd = K_F64(probe), *t = K_F64(tri);
    const int64_t *near = K_I64(nearest), *own = K_I64(owner);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < p; i++) {
        o[i] = 0.0;
        if (!(pd[i * k] > 0)) continue; /* on a probe: on the surface */
        int first = 1;
        for (npy_intp a = 0; a < k; a++) {
            int64_t face = own[near[i * k + a]];
            int seen = 0; /* each (point, triangle) pair once */
            for (npy_intp b = 0; b < a && !seen; b++) seen = own[near[i * k + b]] == face;
            if (seen) continue;
            double d = pair_distance(pt[3 * i], pt[3 * i + 1], pt[3 * i + 2], t + 9 * face);
            o[i] = first ? d : np_minimum(o[i], d);
            first = 0;
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(points);
    Py_XDECREF(probe);
    Py_XDECREF(nearest);
    Py_XDECREF(owner);
    Py_XDECREF(tri);
    Py_XDECREF(out);
    return result;
}

/* Whether face j is a candidate of point (x, y, z) within `reach` (metres): its bounding sphere
 * comes within reach ((p - c)^2 summed x, y, z, as SurfaceIndex._near) and so does its plane
 * (|p . n - offset| <= reach + margin; untrusted faces have n = 0, offset = 0: always kept). */
static inline int candidate(double x, double y, double z, double reach, const double *c,
                            double radius, const double *n, double offset, double margin) {
    double dx = x - c[0], dy = y - c[1], dz = z - c[2];
    double squared = dx * dx;
    squared += dy * dy;
    squared += dz * dz;
    if (!(sqrt(squared) - radius <= reach)) return 0;
    return fabs(x * n[0] + y * n[1] + z * n[2] - offset) <= reach + margin;
}

/* nearest_face(points (p, 3), reach (p,), centres (m, 3), radii (m,), normal (m, 3), offset (m,),
 * margin, tri (m, 3, 3), start (p + 1,) int64 or None, cols (c,) int64 or None) -> (p,) int64:
 * the faces tried are cols[start[i]:start[i + 1]] (ascending) for point i, every face when
 * start is None. */
static PyObject *nearest_face(PyObject *self, PyObject *args) {
    PyObject *points_obj, *reach_obj, *centres_obj, *radii_obj, *normal_obj, *offset_obj, *tri_obj;
    PyObject *start_obj, *cols_obj, *result = NULL;
    double margin;
    const char *kernel = "surface.nearest_face";
    PyArrayObject *start = NULL, *cols = NULL, *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOdOOO:nearest_face", &points_obj, &reach_obj, &centres_obj,
                          &radii_obj, &normal_obj, &offset_obj, &margin, &tri_obj, &start_obj,
                          &cols_obj))
        return NULL;
    PyArrayObject *points = k_array(points_obj, NPY_FLOAT64, 2, 0, kernel, "points");
    PyArrayObject *reach = k_array(reach_obj, NPY_FLOAT64, 1, 0, kernel, "reach");
    PyArrayObject *centres = k_array(centres_obj, NPY_FLOAT64, 2, 0, kernel, "centres");
    PyArrayObject *radii = k_array(radii_obj, NPY_FLOAT64, 1, 0, kernel, "radii");
    PyArrayObject *normal = k_array(normal_obj, NPY_FLOAT64, 2, 0, kernel, "normal");
    PyArrayObject *offset = k_array(offset_obj, NPY_FLOAT64, 1, 0, kernel, "offset");
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    int all = start_obj == Py_None;
    if (!all) {
        start = k_array(start_obj, NPY_INT64, 1, 0, kernel, "start");
        cols = k_array(cols_obj, NPY_INT64, 1, 0, kernel, "cols");
        if (start == NULL || cols == NULL) goto done;
    }
    if (points == NULL || reach == NULL || centres == NULL || radii == NULL || normal == NULL ||
        offset == NULL || tri == NULL)
        goto done;
    npy_intp p = PyArray_DIM(points, 0), m = PyArray_DIM(tri, 0);
    if (k_dim(points, 1, 3, kernel, "points") || k_dim(reach, 0, p, kernel, "reach") ||
        k_dim(centres, 0, m, kernel, "centres") || k_dim(centres, 1, 3, kernel, "centres") ||
        k_dim(radii, 0, m, kernel, "radii") || k_dim(normal, 0, m, kernel, "normal") ||
        k_dim(normal, 1, 3, kernel, "normal") || k_dim(offset, 0, m, kernel, "offset") ||
        k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri"))
        goto done;
    if (!all) {
        if (k_dim(start, 0, p + 1, kernel, "start") || k_indices(cols, m, kernel, "cols")) goto done;
        const int64_t *s = K_I64(start);
        npy_intp c = PyArray_DIM(cols, 0);
        for (npy_intp i = 0; i <= p; i++) {
            if (s[i] < 0 || s[i] > c || (i > 0 && s[i] < s[i - 1])) {
                PyErr_Format(PyExc_ValueError, "%s: start must rise within [0, %zd]", kernel,
                             (Py_ssize_t)c);
                goto done;
            }
        }
    }
    npy_intp dims[1] = {p};
    out = k_zeros(1, dims, NPY_INT64);
    if (out == NULL) goto done;
    const double *pt = K_F64(points), *re = K_F64(reach), *ce = K_F64(centres), *ra = K_F64(radii);
    const double *no = K_F64(normal), *of = K_F64(offset), *t = K_F64(tri);
    const int64_t *s = all ? NULL : K_I64(start), *cs = all ? NULL : K_I64(cols);
    int64_t *o = K_I64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < p; i++) {
        double x = pt[3 * i], y = pt[3 * i + 1], z = pt[3 * i + 2], best = 0.0;
        int64_t found = -1;
        npy_intp lo = all ? 0 : (npy_intp)s[i], hi = all ? m : (npy_intp)s[i + 1];
        for (npy_intp a = lo; a < hi; a++) {
            int64_t j = all ? (int64_t)a : cs[a];
            if (!candidate(x, y, z, re[i], ce + 3 * j, ra[j], no + 3 * j, of[j], margin)) continue;
            double d = pair_distance(x, y, z, t + 9 * j);
            /* The first least distance; a NaN only until a number comes (sorted last). */
            if (found < 0 || d < best || (isnan(best) && !isnan(d))) {
                found = j;
                best = d;
            }
        }
        if (found >= 0) o[i] = found;
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(points);
    Py_XDECREF(reach);
    Py_XDECREF(centres);
    Py_XDECREF(radii);
    Py_XDECREF(normal);
    Py_XDECREF(offset);
    Py_XDECREF(tri);
    Py_XDECREF(start);
    Py_XDECREF(cols);
    Py_XDECREF(out);
    return result;
}


/* 0 when tri is (n, 3, 3) and cand (n, c >= 1) holds indices below `bound`, else -1 with a
 * ValueError (single_bound and chain_bound take one candidate list per triangle). */
static int check_candidates(PyArrayObject *tri, PyArrayObject *cand, npy_intp bound,
                            const char *kernel) {
    npy_intp n = PyArray_DIM(tri, 0);
    if (k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri") ||
        k_dim(cand, 0, n, kernel, "cand") || k_indices(cand, bound, kernel, "cand"))
        return -1;
    if (PyArray_DIM(cand, 1) < 1 && n > 0) {
        PyErr_Format(PyExc_ValueError, "%s: cand needs one candidate per triangle", kernel);
        return -1;
    }
    return 0;
}

/* single_bound(tri (n, 3, 3), cand (n, c) int64 faces, trusted (m,) bool, target (m, 3, 3)) ->
 * (n,) metres: the least over the distinct candidates t of each row of the largest distance of
 * the triangle's corners to t, inf for an untrusted t (np.minimum / np.maximum: NaN wins). */
static PyObject *single_bound(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *cand_obj, *trusted_obj, *target_obj, *result = NULL;
    const char *kernel = "surface.single_bound";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOO:single_bound", &tri_obj, &cand_obj, &trusted_obj,
                          &target_obj))
        return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    PyArrayObject *cand = k_array(cand_obj, NPY_INT64, 2, 0, kernel, "cand");
    PyArrayObject *trusted = k_array(trusted_obj, NPY_BOOL, 1, 0, kernel, "trusted");
    PyArrayObject *target = k_array(target_obj, NPY_FLOAT64, 3, 0, kernel, "target");
    if (tri == NULL || cand == NULL || trusted == NULL || target == NULL) goto done;
    npy_intp n = PyArray_DIM(tri, 0), c = PyArray_DIM(cand, 1), m = PyArray_DIM(target, 0);
    if (k_dim(trusted, 0, m, kernel, "trusted") || k_dim(target, 1, 3, kernel, "target") ||
        k_dim(target, 2, 3, kernel, "target") || check_candidates(tri, cand, m, kernel))
        goto done;
    npy_intp dims[1] = {n};
    out = k_empty(1, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *t = K_F64(tri), *g = K_F64(target);
    const int64_t *cs = K_I64(cand);
    const npy_bool *ok = K_BOOL(trusted);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < n; i++) {
        const double *v = t + 9 * i;
        const int64_t *row = cs + c * i;
        for (npy_intp a = 0; a < c; a++) {
            int seen = 0; /* each (triangle, face) pair once */
            for (npy_intp b = 0; b < a && !seen; b++) seen = row[b] == row[a];
            if (seen) continue;
            double worst = INFINITY;
            if (ok[row[a]]) {
                const double *f = g + 9 * row[a];
                worst = np_maximum(np_maximum(pair_distance(v[0], v[1], v[2], f),
                                              pair_distance(v[3], v[4], v[5], f)),
                                   pair_distance(v[6], v[7], v[8], f));
            }
            o[i] = a == 0 ? worst : np_minimum(o[i], worst);
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(tri);
    Py_XDECREF(cand);
    Py_XDECREF(trusted);
    Py_XDECREF(target);
    Py_XDECREF(out);
    return result;
}

/* Distance (metres) from (x, y, z) to the segment s-e (hausdorff._segment_distance's order: the
 * parameter clipped to [0, 1], 0 on a zero-length segment, a NaN kept). */
static inline double segment_distance(double x, double y, double z, const double *s,
                                      const double *e) {
    double d0 = e[0] - s[0], d1 = e[1] - s[1], d2 = e[2] - s[2];
    double w0 = x - s[0], w1 = y - s[1], w2 = z - s[2];
    double length2 = d0 * d0 + d1 * d1 + d2 * d2;
    double along = w0 * d0 + w1 * d1 + w2 * d2;
    double t = length2 > 0 ? along / length2 : 0.0;
    t = t < 0 ? 0.0 : (t > 1 ? 1.0 : t);
    double e0 = w0 - t * d0, e1 = w1 - t * d1, e2 = w2 - t * d2;
    return sqrt(e0 * e0 + e1 * e1 + e2 * e2);
}

/* chain_bound(tri (n, 3, 3), cand (n, c) int64 chains, start (q, 3), end (q, 3), slack (q,)) ->
 * (n,) metres: the least over the row's chains of the largest distance of the triangle's corners
 * to the chain's segment, plus its slack (NaN wins, as numpy's max and min). */
static PyObject *chain_bound(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *cand_obj, *start_obj, *end_obj, *slack_obj, *result = NULL;
    const char *kernel = "surface.chain_bound";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOO:chain_bound", &tri_obj, &cand_obj, &start_obj, &end_obj,
                          &slack_obj))
        return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    PyArrayObject *cand = k_array(cand_obj, NPY_INT64, 2, 0, kernel, "cand");
    PyArrayObject *start = k_array(start_obj, NPY_FLOAT64, 2, 0, kernel, "start");
    PyArrayObject *end = k_array(end_obj, NPY_FLOAT64, 2, 0, kernel, "end");
    PyArrayObject *slack = k_array(slack_obj, NPY_FLOAT64, 1, 0, kernel, "slack");
    if (tri == NULL || cand == NULL || start == NULL || end == NULL || slack == NULL) goto done;
    npy_intp n = PyArray_DIM(tri, 0), c = PyArray_DIM(cand, 1), q = PyArray_DIM(slack, 0);
    if (k_dim(start, 0, q, kernel, "start") || k_dim(start, 1, 3, kernel, "start") ||
        k_dim(end, 0, q, kernel, "end") || k_dim(end, 1, 3, kernel, "end") ||
        check_candidates(tri, cand, q, kernel))
        goto done;
    npy_intp dims[1] = {n};
    out = k_empty(1, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *t = K_F64(tri), *st = K_F64(start), *en = K_F64(end), *sl = K_F64(slack);
    const int64_t *cs = K_I64(cand);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < n; i++) {
        const double *v = t + 9 * i;
        for (npy_intp a = 0; a < c; a++) {
            int64_t j = cs[c * i + a];
            const double *s = st + 3 * j, *e = en + 3 * j;
            double worst = np_maximum(np_maximum(segment_distance(v[0], v[1], v[2], s, e),
                                                 segment_distance(v[3], v[4], v[5], s, e)),
                                      segment_distance(v[6], v[7], v[8], s, e)) +
                           sl[j];
            o[i] = a == 0 ? worst : np_minimum(o[i], worst);
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(tri);
    Py_XDECREF(cand);
    Py_XDECREF(start);
    Py_XDECREF(end);
    Py_XDECREF(slack);
    Py_XDECREF(out);
    return result;
}

/* The corners' distances to face f (3,) and the bound of the cell of corners with side >= 0
 * (above) or <= 0 (below): np.maximum over the cell's corners, 0 for the others. */
static inline double cell_bound(const double *d, const double *s, int above) {
    double x[3];
    for (int k = 0; k < 3; k++) x[k] = (above ? s[k] >= 0 : s[k] <= 0) ? d[k] : 0.0;
    return np_maximum(np_maximum(x[0], x[1]), x[2]);
}

/* The two-cell bound of triangle v (9,) between faces fi and fj (hausdorff._pair_bound, float
 * for float): the cut where their planes are equally far (signed), each cell bounded by either
 * face, the lesser assignment, at least the crossing points' distances, plus 1e-12 x the largest
 * coordinate. */
static double pair_value(const double *v, const double *ni, double oi, const double *fi,
                         const double *nj, double oj, const double *fj) {
    double s[3], ci[3], cj[3], on_cut[3];
    for (int k = 0; k < 3; k++) {
        const double *p = v + 3 * k;
        s[k] = ((p[0] * ni[0] + p[1] * ni[1] + p[2] * ni[2]) - oi) -
               ((p[0] * nj[0] + p[1] * nj[1] + p[2] * nj[2]) - oj);
        ci[k] = pair_distance(p[0], p[1], p[2], fi);
        cj[k] = pair_distance(p[0], p[1], p[2], fj);
    }
    for (int k = 0; k < 3; k++) {
        int next = (k + 1) % 3;
        on_cut[k] = 0.0;
        if (!(s[k] * s[next] < 0)) continue;
        double share = s[k] / (s[k] - s[next]);
        const double *p = v + 3 * k, *q = v + 3 * next;
        double x = p[0] + share * (q[0] - p[0]), y = p[1] + share * (q[1] - p[1]),
               z = p[2] + share * (q[2] - p[2]);
        on_cut[k] = np_maximum(pair_distance(x, y, z, fi), pair_distance(x, y, z, fj));
    }
    double value = np_minimum(np_maximum(cell_bound(ci, s, 0), cell_bound(cj, s, 1)),
                              np_maximum(cell_bound(ci, s, 1), cell_bound(cj, s, 0)));
    value = np_maximum(value, np_maximum(np_maximum(on_cut[0], on_cut[1]), on_cut[2]));
    double largest = fabs(v[0]);
    for (int k = 1; k < 9; k++) largest = np_maximum(largest, fabs(v[k]));
    return value + 1e-12 * largest;
}

/* pair_bound(tri (n, 3, 3), nearest (n,) int64, other (n, 3) int64, trusted (m,) bool, normal
 * (m, 3), offset (m,), target (m, 3, 3)) -> (n,) metres: the least two-cell bound over the pairs
 * (nearest, other[k]) of distinct trusted faces (each other face once), inf without one. */
static PyObject *pair_bound(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *nearest_obj, *other_obj, *trusted_obj, *normal_obj, *offset_obj;
    PyObject *target_obj, *result = NULL;
    const char *kernel = "surface.pair_bound";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOO:pair_bound", &tri_obj, &nearest_obj, &other_obj,
                          &trusted_obj, &normal_obj, &offset_obj, &target_obj))
        return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    PyArrayObject *nearest = k_array(nearest_obj, NPY_INT64, 1, 0, kernel, "nearest");
    PyArrayObject *other = k_array(other_obj, NPY_INT64, 2, 0, kernel, "other");
    PyArrayObject *trusted = k_array(trusted_obj, NPY_BOOL, 1, 0, kernel, "trusted");
    PyArrayObject *normal = k_array(normal_obj, NPY_FLOAT64, 2, 0, kernel, "normal");
    PyArrayObject *offset = k_array(offset_obj, NPY_FLOAT64, 1, 0, kernel, "offset");
    PyArrayObject *target = k_array(target_obj, NPY_FLOAT64, 3, 0, kernel, "target");
    if (tri == NULL || nearest == NULL || other == NULL || trusted == NULL || normal == NULL ||
        offset == NULL || target == NULL)
        goto done;
    npy_intp n = PyArray_DIM(tri, 0), m = PyArray_DIM(target, 0);
    if (k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri") ||
        k_dim(nearest, 0, n, kernel, "nearest") || k_dim(other, 0, n, kernel, "other") ||
        k_dim(other, 1, 3, kernel, "other") || k_dim(trusted, 0, m, kernel, "trusted") ||
        k_dim(normal, 0, m, kernel, "normal") || k_dim(normal, 1, 3, kernel, "normal") ||
        k_dim(offset, 0, m, kernel, "offset") || k_dim(target, 1, 3, kernel, "target") ||
        k_dim(target, 2, 3, kernel, "target") || k_indices(nearest, m, kernel, "nearest") ||
        k_indices(other, m, kernel, "other"))
        goto done;
    npy_intp dims[1] = {n};
    out = k_empty(1, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *t = K_F64(tri), *no = K_F64(normal), *of = K_F64(offset), *g = K_F64(target);
    const int64_t *ne = K_I64(nearest), *ot = K_I64(other);
    const npy_bool *ok = K_BOOL(trusted);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp r = 0; r < n; r++) {
        int64_t i = ne[r];
        const int64_t *js = ot + 3 * r;
        o[r] = INFINITY;
        for (int k = 0; k < 3; k++) {
            int64_t j = js[k];
            if (j == i || !ok[j] || !ok[i] || (k >= 1 && j == js[0]) || (k == 2 && j == js[1]))
                continue;
            double value = pair_value(t + 9 * r, no + 3 * i, of[i], g + 9 * i, no + 3 * j, of[j],
                                      g + 9 * j);
            o[r] = np_minimum(o[r], value);
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(tri);
    Py_XDECREF(nearest);
    Py_XDECREF(other);
    Py_XDECREF(trusted);
    Py_XDECREF(normal);
    Py_XDECREF(offset);
    Py_XDECREF(target);
    Py_XDECREF(out);
    return result;
}

/* centres_radii(tri (m, 3, 3)) -> (centres (m, 3), radii (m,)) metres: each triangle's corner
 * mean (tri.mean(axis=1): 0.0 + a + b + c in that order, then / 3.0) and the largest distance of
 * its corners to it (np.sqrt(((tri - centres[:, None]) ** 2).sum(-1)).max(axis=1), NaN wins). */
static PyObject *centres_radii(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *result = NULL;
    const char *kernel = "surface.centres_radii";
    PyArrayObject *centres = NULL, *radii = NULL;
    if (!PyArg_ParseTuple(args, "O:centres_radii", &tri_obj)) return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    if (tri == NULL || k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri"))
        goto done;
    npy_intp m = PyArray_DIM(tri, 0);
    npy_intp dims[2] = {m, 3};
    centres = k_empty(2, dims, NPY_FLOAT64);
    radii = k_empty(1, dims, NPY_FLOAT64);
    if (centres == NULL || radii == NULL) goto done;
    const double *t = K_F64(tri);
    double *c = K_F64(centres), *r = K_F64(radii);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++) {
        const double *v = t + 9 * i;
        double *ci = c + 3 * i, far[3];
        for (int a = 0; a < 3; a++) ci[a] = (((0.0 + v[a]) + v[3 + a]) + v[6 + a]) / 3.0;
        for (int k = 0; k < 3; k++) {
            double dx = v[3 * k] - ci[0], dy = v[3 * k + 1] - ci[1], dz = v[3 * k + 2] - ci[2];
            far[k] = sqrt(((0.0 + dx * dx) + dy * dy) + dz * dz);
        }
        r[i] = np_maximum(np_maximum(far[0], far[1]), far[2]);
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("OO", centres, radii);
done:
    Py_XDECREF(tri);
    Py_XDECREF(centres);
    Py_XDECREF(radii);
    return result;
}

/* np.einsum("mkj,mj->mk")'s sum for one corner p (3,) and axis a (3,): from 0.0 as x, z, y, the
 * order numpy's kernel takes (tests/test_surface_prep.py checks it against numpy). */
static inline double einsum_dot(const double *p, const double *a) {
    return ((0.0 + p[0] * a[0]) + p[2] * a[2]) + p[1] * a[1];
}

/* split4(tri (n, 3, 3)) -> (4n, 3, 3) metres: each triangle a, b, c split at its edge midpoints
 * ab = 0.5 * (a + b), bc, ca into (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca), rows
 * 4i..4i+3 (hausdorff.split4's numpy form, float for float). */
static PyObject *split4(PyObject *self, PyObject *args) {
    PyObject *tri_obj;
    const char *kernel = "surface.split4";
    if (!PyArg_ParseTuple(args, "O:split4", &tri_obj)) return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    if (tri == NULL) return NULL;
    if (k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri")) {
        Py_DECREF(tri);
        return NULL;
    }
    npy_intp n = PyArray_DIM(tri, 0);
    npy_intp dims[3] = {4 * n, 3, 3};
    PyArrayObject *out = k_empty(3, dims, NPY_FLOAT64);
    if (out != NULL) {
        const double *t = K_F64(tri);
        double *o = K_F64(out);
        Py_BEGIN_ALLOW_THREADS
        for (npy_intp i = 0; i < n; i++) {
            const double *a = t + 9 * i, *b = a + 3, *c = a + 6;
            double ab[3], bc[3], ca[3];
            for (int k = 0; k < 3; k++) {
                ab[k] = 0.5 * (a[k] + b[k]);
                bc[k] = 0.5 * (b[k] + c[k]);
                ca[k] = 0.5 * (c[k] + a[k]);
            }
            const double *rows[12] = {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca};
            double *child = o + 36 * i;
            for (int r = 0; r < 12; r++) memcpy(child + 3 * r, rows[r], 3 * sizeof(double));
        }
        Py_END_ALLOW_THREADS
    }
    Py_DECREF(tri);
    return (PyObject *)out;
}

/* project(tri (m, 3, 3), u (r, 3), v (r, 3), region (m,) int64 in [0, r)) -> (m, 3, 2) metres:
 * each corner's coordinates on its region's in-plane axes (hausdorff._Regions.tri2: two
 * np.einsum("mkj,mj->mk") stacked on the last axis). */
static PyObject *project(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *u_obj, *v_obj, *region_obj, *result = NULL;
    const char *kernel = "surface.project";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOO:project", &tri_obj, &u_obj, &v_obj, &region_obj))
        return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    PyArrayObject *u = k_array(u_obj, NPY_FLOAT64, 2, 0, kernel, "u");
    PyArrayObject *v = k_array(v_obj, NPY_FLOAT64, 2, 0, kernel, "v");
    PyArrayObject *region = k_array(region_obj, NPY_INT64, 1, 0, kernel, "region");
    if (tri == NULL || u == NULL || v == NULL || region == NULL) goto done;
    npy_intp m = PyArray_DIM(tri, 0), r = PyArray_DIM(u, 0);
    if (k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri") ||
        k_dim(u, 1, 3, kernel, "u") || k_dim(v, 0, r, kernel, "v") ||
        k_dim(v, 1, 3, kernel, "v") || k_dim(region, 0, m, kernel, "region") ||
        k_indices(region, r, kernel, "region"))
        goto done;
    npy_intp dims[3] = {m, 3, 2};
    out = k_empty(3, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    const double *t = K_F64(tri), *uu = K_F64(u), *vv = K_F64(v);
    const int64_t *g = K_I64(region);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++) {
        for (int k = 0; k < 3; k++) {
            const double *p = t + 9 * i + 3 * k;
            o[6 * i + 2 * k] = einsum_dot(p, uu + 3 * g[i]);
            o[6 * i + 2 * k + 1] = einsum_dot(p, vv + 3 * g[i]);
        }
    }
    Py_END_ALLOW_THREADS
    result = (PyObject *)out;
    out = NULL;
done:
    Py_XDECREF(tri);
    Py_XDECREF(u);
    Py_XDECREF(v);
    Py_XDECREF(region);
    Py_XDECREF(out);
    return result;
}

/* planes(tri (m, 3, 3), cross (m, 3), region (m,) int64 in [0, r), r) -> (normal (r, 3), offset
 * (r,), slack (r,)) metres: hausdorff._planes float for float. The area-weighted normal (np.add.at:
 * each face's cross added in face order to 0.0), made unit (np.linalg.norm's sqrt of the squares
 * summed from 0.0 in x, y, z order; (0, 0, 1) for a zero or NaN length), each corner's height
 * (np.einsum("mkj,mj->mk"), einsum_dot), the highest and lowest per region (np.maximum.at / minimum.at
 * of each face's np.max / np.min: NaN wins) and halfway between / half the spread. */
static PyObject *planes(PyObject *self, PyObject *args) {
    PyObject *tri_obj, *cross_obj, *region_obj, *result = NULL;
    Py_ssize_t r;
    const char *kernel = "surface.planes";
    PyArrayObject *normal = NULL, *offset = NULL, *slack = NULL;
    double *low = NULL;
    if (!PyArg_ParseTuple(args, "OOOn:planes", &tri_obj, &cross_obj, &region_obj, &r))
        return NULL;
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri");
    PyArrayObject *cross = k_array(cross_obj, NPY_FLOAT64, 2, 0, kernel, "cross");
    PyArrayObject *region = k_array(region_obj, NPY_INT64, 1, 0, kernel, "region");
    if (tri == NULL || cross == NULL || region == NULL) goto done;
    npy_intp m = PyArray_DIM(tri, 0);
    if (r < 0) {
        PyErr_Format(PyExc_ValueError, "%s: r must be >= 0", kernel);
        goto done;
    }
    if (k_dim(tri, 1, 3, kernel, "tri") || k_dim(tri, 2, 3, kernel, "tri") ||
        k_dim(cross, 0, m, kernel, "cross") || k_dim(cross, 1, 3, kernel, "cross") ||
        k_dim(region, 0, m, kernel, "region") || k_indices(region, r, kernel, "region"))
        goto done;
    npy_intp dims[2] = {r, 3};
    normal = k_zeros(2, dims, NPY_FLOAT64);
    offset = k_empty(1, dims, NPY_FLOAT64);
    slack = k_empty(1, dims, NPY_FLOAT64);
    low = malloc((size_t)(r > 0 ? r : 1) * sizeof(double));
    if (normal == NULL || offset == NULL || slack == NULL) goto done;
    if (low == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    const double *t = K_F64(tri), *c = K_F64(cross);
    const int64_t *g = K_I64(region);
    double *n = K_F64(normal), *high = K_F64(offset), *o = K_F64(offset), *sl = K_F64(slack);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < m; i++)
        for (int a = 0; a < 3; a++) n[3 * g[i] + a] = n[3 * g[i] + a] + c[3 * i + a];
    for (npy_intp j = 0; j < r; j++) {
        double *v = n + 3 * j;
        double length = sqrt(((0.0 + v[0] * v[0]) + v[1] * v[1]) + v[2] * v[2]);
        if (length > 0) {
            v[0] = v[0] / length;
            v[1] = v[1] / length;
            v[2] = v[2] / length;
        } else {
            v[0] = 0.0;
            v[1] = 0.0;
            v[2] = 1.0;
        }
        high[j] = -INFINITY;
        low[j] = INFINITY;
    }
    for (npy_intp i = 0; i < m; i++) {
        const double *v = n + 3 * g[i], *p = t + 9 * i;
        double h[3];
        for (int k = 0; k < 3; k++)
            h[k] = einsum_dot(p + 3 * k, v);
        high[g[i]] = np_maximum(high[g[i]], np_maximum(np_maximum(h[0], h[1]), h[2]));
        low[g[i]] = np_minimum(low[g[i]], np_minimum(np_minimum(h[0], h[1]), h[2]));
    }
    for (npy_intp j = 0; j < r; j++) {
        double hi = high[j];
        o[j] = 0.5 * (hi + low[j]);
        sl[j] = 0.5 * (hi - low[j]);
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("OOO", normal, offset, slack);
done:
    free(low);
    Py_XDECREF(tri);
    Py_XDECREF(cross);
    Py_XDECREF(region);
    Py_XDECREF(normal);
    Py_XDECREF(offset);
    Py_XDECREF(slack);
    return result;
}

static PyMethodDef methods[] = {
    {"upper", upper, METH_VARARGS,
     "upper(points, probe_distance, nearest, owner, tri): each point's upper bound, metres"},
    {"nearest_face", nearest_face, METH_VARARGS,
     "nearest_face(points, reach, centres, radii, normal, offset, margin, tri, start, cols): "
     "each point's nearest face among its candidates"},
    {"single_bound", single_bound, METH_VARARGS,
     "single_bound(tri, cand, trusted, target): least largest corner distance to a candidate"},
    {"chain_bound", chain_bound, METH_VARARGS,
     "chain_bound(tri, cand, start, end, slack): least largest corner distance to a chain"},
    {"pair_bound", pair_bound, METH_VARARGS,
     "pair_bound(tri, nearest, other, trusted, normal, offset, target): two-cell bound"},
    {"centres_radii", centres_radii, METH_VARARGS,
     "centres_radii(tri): each triangle's corner mean and bounding radius"},
    {"split4", split4, METH_VARARGS, "split4(tri): each triangle split at its edge midpoints"},
    {"project", project, METH_VARARGS,
     "project(tri, u, v, region): each corner on its region's in-plane axes"},
    {"planes", planes, METH_VARARGS,
     "planes(tri, cross, region, r): each region's unit normal, offset and slack"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(surface, "Point-to-surface queries of the certified Hausdorff bound.", methods)
