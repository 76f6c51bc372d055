/* Planar regions of a triangle mesh: faces joined across every shared edge where their unit
 * normals agree (cosine above cos_limit) and the second face's centroid lies on the first's plane
 * (within plane_m metres), then numbered by their lowest face (union-find with path halving, the
 * larger root linked under the smaller: union_find.h).
 *
 * Data: faces (m, 3) int64 into positions (k, 3) float64 metres (any one frame); the faces'
 * sorted edge keys and their side permutation (geometry.sorted_edge_keys: side 3 f + i runs from
 * corner i of face f to the next). The floats are those of the former numpy form, operation for
 * operation (tests/test_planar_region_kernels.py keeps it as the reference and checks labels
 * equal).
 */
#include "faces.h"
#include "union_find.h"

/* The labels (m) of faces (m, 3) into positions; returns -1 when scratch memory is lacking. */
static int labels_of(const double *positions, const int64_t *faces, int64_t m,
                     const int64_t *groups, int use_groups, const int64_t *keys,
                     const int64_t *order, int64_t n, double cos_limit, double plane_m,
                     int64_t *labels) {
    double *normal = malloc((size_t)(3 * m + 1) * sizeof(double));
    double *centroid = malloc((size_t)(3 * m + 1) * sizeof(double));
    int64_t *parent = malloc((size_t)(m + 1) * sizeof(int64_t));
    int status = -1;
    if (normal == NULL || centroid == NULL || parent == NULL) goto done;
    for (int64_t f = 0; f < m; f++) {
        const double *pa = positions + 3 * faces[3 * f], *pb = positions + 3 * faces[3 * f + 1],
                     *pc = positions + 3 * faces[3 * f + 2];
        double cross[3];
        face_cross(positions, faces + 3 * f, cross);
        double nx = cross[0], ny = cross[1], nz = cross[2];
        double length = k_max(sqrt(nx * nx + ny * ny + nz * nz), 1e-30);
        normal[3 * f] = nx / length;
        normal[3 * f + 1] = ny / length;
        normal[3 * f + 2] = nz / length;
        for (int i = 0; i < 3; i++) centroid[3 * f + i] = (0.0 + pa[i] + pb[i] + pc[i]) / 3;
    }
    for (int64_t f = 0; f < m; f++) parent[f] = f;
    for (int64_t s = 0; s + 1 < n; s++) {
        if (keys[s] != keys[s + 1]) continue;
        int64_t f = order[s] / 3, g = order[s + 1] / 3;
        if (use_groups && groups[f] != groups[g]) continue;
        const double *nf = normal + 3 * f, *ng = normal + 3 * g, *cg = centroid + 3 * g;
        double cos = nf[0] * ng[0] + nf[1] * ng[1] + nf[2] * ng[2];
        const double *pa = positions + 3 * faces[3 * f];
        double height =
            (cg[0] - pa[0]) * nf[0] + (cg[1] - pa[1]) * nf[1] + (cg[2] - pa[2]) * nf[2];
        if (!(cos > cos_limit && fabs(height) < plane_m)) continue;
        uf_join(parent, f, g);
    }
    int64_t count = 0;
    for (int64_t f = 0; f < m; f++) { /* parents are lower than their children: one pass settles */
        parent[f] = parent[parent[f]];
        labels[f] = parent[f] == f ? count++ : labels[parent[f]];
    }
    status = 0;
done:
    free(normal);
    free(centroid);
    free(parent);
    return status;
}

/* labels(positions (k, 3) float64, faces (m, 3) int64, groups (m,) int64 (read when use_groups),
 * use_groups, keys (n,) int64, order (n,) int64, cos_limit, plane_m) -> (m,) int64 region of
 * every face. */
static PyObject *labels(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *faces_obj, *groups_obj, *keys_obj, *order_obj;
    int use_groups;
    double cos_limit, plane_m;
    const char *kernel = "planar_region.labels";
    PyArrayObject *labels = NULL;
    if (!PyArg_ParseTuple(args, "OOOpOOdd:labels", &positions_obj, &faces_obj, &groups_obj,
                          &use_groups, &keys_obj, &order_obj, &cos_limit, &plane_m))
        return NULL;
    PyArrayObject *positions = k_array(positions_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *groups = k_array(groups_obj, NPY_INT64, 1, 0, kernel, "groups");
    PyArrayObject *keys = k_array(keys_obj, NPY_INT64, 1, 0, kernel, "keys");
    PyArrayObject *order = k_array(order_obj, NPY_INT64, 1, 0, kernel, "order");
    if (positions == NULL || faces == NULL || groups == NULL || keys == NULL || order == NULL)
        goto done;
    npy_intp m = PyArray_DIM(faces, 0), n = PyArray_DIM(keys, 0);
    if (k_dim(positions, 1, 3, kernel, "positions") || k_dim(faces, 1, 3, kernel, "faces") ||
        k_indices(faces, PyArray_DIM(positions, 0), kernel, "faces") ||
        (use_groups && k_dim(groups, 0, m, kernel, "groups")) ||
        k_dim(order, 0, n, kernel, "order") || k_indices(order, 3 * (int64_t)m, kernel, "order"))
        goto done;
    labels = k_empty(1, &m, NPY_INT64);
    if (labels == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = labels_of(K_F64(positions), K_I64(faces), m, K_I64(groups), use_groups, K_I64(keys),
                       K_I64(order), n, cos_limit, plane_m, K_I64(labels));
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        Py_CLEAR(labels);
    }
done:
    Py_XDECREF(positions);
    Py_XDECREF(faces);
    Py_XDECREF(groups);
    Py_XDECREF(keys);
    Py_XDECREF(order);
    return (PyObject *)labels;
}

static PyMethodDef methods[] = {
    {"labels", labels, METH_VARARGS,
     "labels(positions, faces, groups, use_groups, keys, order, cos_limit, plane_m) -> (m,) "
     "int64 planar region of every face"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(planar_region, "Planar regions of a triangle mesh: coplanar faces joined across edges.",
         methods)
