/* Face lists (m, 3) int64 into positions (k, 3) float64: the (faces, vertex_count) argument of the
 * kernels over a face list (edge.c, boundary.c) and a face's cross product. */
#ifndef EXPORTER_MESH_FACES_H
#define EXPORTER_MESH_FACES_H

#include "kernels.h"

/* Parses `args` (faces (m, 3) int64, vertex_count >= 0) of `kernel` with `format`; the faces'
 * ids must lie in [0, vertex_count + slack). Returns faces as a new reference and sets
 * *vertex_count, or NULL with a ValueError. */
static inline PyArrayObject *faces_argument(PyObject *args, const char *format, const char *kernel,
                                            int64_t slack, int64_t *vertex_count) {
    PyObject *faces_obj;
    long long count;
    if (!PyArg_ParseTuple(args, format, &faces_obj, &count)) return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    if (faces == NULL) return NULL;
    if (count < 0) {
        PyErr_Format(PyExc_ValueError, "%s: vertex_count is negative", kernel);
    } else if (k_dim(faces, 1, 3, kernel, "faces") == 0 &&
               k_indices(faces, count + slack, kernel, "faces") == 0) {
        *vertex_count = count;
        return faces;
    }
    Py_DECREF(faces);
    return NULL;
}

/* (b - a) x (c - a) of the face with corner ids face[0..2] into positions p (k, 3), in the
 * operations of geometry.cross_rows' numpy form (so the bits are its). */
static inline void face_cross(const double *p, const int64_t *face, double *out) {
    const double *pa = p + 3 * face[0], *pb = p + 3 * face[1], *pc = p + 3 * face[2];
    double ux = pb[0] - pa[0], uy = pb[1] - pa[1], uz = pb[2] - pa[2];
    double vx = pc[0] - pa[0], vy = pc[1] - pa[1], vz = pc[2] - pa[2];
    out[0] = uy * vz - uz * vy;
    out[1] = uz * vx - ux * vz;
    out[2] = ux * vy - uy * vx;
}

#endif
