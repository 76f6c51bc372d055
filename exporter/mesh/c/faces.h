/* The (faces, vertex_count) arguments of the kernels over a face list (edge.c, boundary.c). */
#ifndef EXPORTER_MESH_FACES_H
#define EXPORTER_MESH_FACES_H

#include "kernels.h"

/* Parses `args` (faces (m, 3) int64, vertex_count >= 0) of `kernel` with `format`; the faces'
 * ids must lie in [0, vertex_count + slack). Returns faces as a new reference and sets
 * *vertex_count, or NULL with a ValueError. */
static PyArrayObject *faces_argument(PyObject *args, const char *format, const char *kernel,
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

#endif
