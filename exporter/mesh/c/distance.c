/* Exact distance from points to triangles: one (point, triangle) pair at a time.
 *
 * Source: Ericson, "Real-Time Collision Detection" (2005), 5.1.5 (closest point on a triangle by
 * its Voronoi regions). The regions are tested in the order the former vectorised numpy form
 * applied them (vertex A, B, C, then edges AB, AC, BC, then the interior), with its float
 * operations in its order, so the results are the same bits (tests/test_distance_kernels.py). A
 * degenerate (zero-area) triangle whose formula gives NaN takes its nearest corner's distance.
 * Frame-free: any one Cartesian frame, metres.
 */
#include "kernels.h"

/* Distance (metres) from point (px, py, pz) to the triangle t[9] (corner after corner). */
static double pair_distance(double px, double py, double pz, const double *t) {
    double ax = t[0], ay = t[1], az = t[2];
    double bx = t[3], by = t[4], bz = t[5];
    double cx = t[6], cy = t[7], cz = t[8];
    double abx = bx - ax, aby = by - ay, abz = bz - az;
    double acx = cx - ax, acy = cy - ay, acz = cz - az;
    double apx = px - ax, apy = py - ay, apz = pz - az;
    double d1 = abx * apx + aby * apy + abz * apz;
    double d2 = acx * apx + acy * apy + acz * apz;
    double bpx = px - bx, bpy = py - by, bpz = pz - bz;
    double d3 = abx * bpx + aby * bpy + abz * bpz;
    double d4 = acx * bpx + acy * bpy + acz * bpz;
    double cpx = px - cx, cpy = py - cy, cpz = pz - cz;
    double d5 = abx * cpx + aby * cpy + abz * cpz;
    double d6 = acx * cpx + acy * cpy + acz * cpz;
    double va = d3 * d6 - d5 * d4;
    double vb = d5 * d2 - d1 * d6;
    double vc = d1 * d4 - d3 * d2;
    double qx, qy, qz, s;
    if (d1 <= 0 && d2 <= 0) {
        qx = ax; qy = ay; qz = az;
    } else if (d3 >= 0 && d4 <= d3) {
        qx = bx; qy = by; qz = bz;
    } else if (d6 >= 0 && d5 <= d6) {
        qx = cx; qy = cy; qz = cz;
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        s = d1 / (d1 - d3);
        s = s < 0 ? 0.0 : (s > 1 ? 1.0 : s); /* a NaN stays NaN (as np.clip) */
        qx = ax + s * abx; qy = ay + s * aby; qz = az + s * abz;
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        s = d2 / (d2 - d6);
        s = s < 0 ? 0.0 : (s > 1 ? 1.0 : s);
        qx = ax + s * acx; qy = ay + s * acy; qz = az + s * acz;
    } else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        s = s < 0 ? 0.0 : (s > 1 ? 1.0 : s);
        qx = bx + s * (cx - bx); qy = by + s * (cy - by); qz = bz + s * (cz - bz);
    } else {
        double denom = va + vb + vc;
        double v = denom != 0 ? vb / denom : 0.0;
        double w = denom != 0 ? vc / denom : 0.0;
        qx = ax + abx * v + acx * w; qy = ay + aby * v + acy * w; qz = az + abz * v + acz * w;
    }
    double ox = px - qx, oy = py - qy, oz = pz - qz;
    double distance = sqrt(ox * ox + oy * oy + oz * oz);
    if (isnan(distance)) {
        double da = sqrt(apx * apx + apy * apy + apz * apz);
        double db = sqrt(bpx * bpx + bpy * bpy + bpz * bpz);
        double dc = sqrt(cpx * cpx + cpy * cpy + cpz * cpz);
        distance = k_min(k_min(da, db), dc);
    }
    return distance;
}

/* pairs(points (n, 3) float64, tri (n, 3, 3) float64, out (n,) float64): out[i] is the distance
 * from points[i] to tri[i]. */
static PyObject *pairs(PyObject *self, PyObject *args) {
    PyObject *points_obj, *tri_obj, *out_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "OOO:pairs", &points_obj, &tri_obj, &out_obj)) return NULL;
    PyArrayObject *points = k_array(points_obj, NPY_FLOAT64, 2, 0, "distance.pairs", "points");
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, "distance.pairs", "tri");
    PyArrayObject *out = k_array(out_obj, NPY_FLOAT64, 1, 1, "distance.pairs", "out");
    if (points == NULL || tri == NULL || out == NULL) goto done;
    npy_intp n = PyArray_DIM(points, 0);
    if (k_dim(points, 1, 3, "distance.pairs", "points") || k_dim(tri, 0, n, "distance.pairs", "tri") ||
        k_dim(tri, 1, 3, "distance.pairs", "tri") || k_dim(tri, 2, 3, "distance.pairs", "tri") ||
        k_dim(out, 0, n, "distance.pairs", "out"))
        goto done;
    const double *p = K_F64(points), *t = K_F64(tri);
    double *o = K_F64(out);
    Py_BEGIN_ALLOW_THREADS
    for (npy_intp i = 0; i < n; i++) o[i] = pair_distance(p[3 * i], p[3 * i + 1], p[3 * i + 2], t + 9 * i);
    Py_END_ALLOW_THREADS
    result = Py_NewRef(Py_None);
done:
    Py_XDECREF(points);
    Py_XDECREF(tri);
    Py_XDECREF(out);
    return result;
}

static PyMethodDef methods[] = {
    {"pairs", pairs, METH_VARARGS, "pairs(points, tri, out): out[i] = distance(points[i], tri[i]), metres"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(distance, "Exact point-triangle distance (Ericson 5.1.5), one pair at a time.", methods)
