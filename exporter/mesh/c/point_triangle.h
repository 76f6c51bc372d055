/* Exact distance from a point to a triangle, one pair: what distance.c and surface.c share.
 *
 * Source: Ericson, "Real-Time Collision Detection" (2005), 5.1.5 (closest point on a triangle by
 * its Voronoi regions), in the float order of the former numpy form (see distance.c).
 * Frame-free: any one Cartesian frame, metres.
 */
#ifndef EXPORTER_MESH_POINT_TRIANGLE_H
#define EXPORTER_MESH_POINT_TRIANGLE_H

#include "kernels.h"

/* Distance (metres) from point (px, py, pz) to the triangle t[9] (corner after corner). */
static inline double pair_distance(double px, double py, double pz, const double *t) {
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

#endif
