/* Faces split into fans at the points on one of their sides (the step of
 * exporter.mesh.slits.split_sides).
 *
 * A face (a, b, c) with points v1..vn inside its side a -> b becomes (a, v1, c), (v1, v2, c), ...,
 * (vn, b, c), each point's UV interpolated along the side in float64 and stored as float32 (glTF
 * UV convention). Each face is split on its lowest side with points; the points on its other
 * sides move to the fan faces now holding those sides. Kept faces first (in order), then every
 * fan's faces ending at a point, then the fans' last faces, as the former numpy form ordered them
 * (tests/test_split_kernels.py keeps it as the reference and checks every array equal). Data:
 * faces (m, 3) int64, corner_uvs (m, 3, 2) float32, points as (side 3 f + i, vertex, t) sorted by
 * side then t.
 */
#include "kernels.h"
#include "sorted.h"

/* What the split makes of the points: each face's points on its lowest side are chosen. */
typedef struct {
    int64_t chosen;  /* points on their face's lowest side (n) */
    int64_t groups;  /* faces split */
    int64_t sides;   /* fans (one per face split: one side each) */
} Split;

/* Marks chosen (p) and split (m) for the points on sides side (p,) ascending. */
static Split choose(const int64_t *side, int64_t p, npy_bool *chosen, npy_bool *split) {
    Split s = {0, 0, 0};
    int64_t lowest = 0;
    for (int64_t j = 0; j < p; j++) {
        int64_t f = side[j] / 3;
        if (j == 0 || f != side[j - 1] / 3) {
            lowest = side[j];
            s.groups++;
            split[f] = 1;
        }
        chosen[j] = side[j] == lowest;
        s.chosen += chosen[j];
    }
    for (int64_t j = 0; j < p; j++)
        s.sides += chosen[j] && (j == p - 1 || !chosen[j + 1] || side[j + 1] != side[j]);
    return s;
}

/* The split itself: out (total, 3), uvs (total, 3, 2) when has_uvs, source (total,) and the
 * rest (p - n,): moved sides, vertices and t, ascending by side then t. Returns -1 when scratch
 * memory is lacking. */
static int fans(const int64_t *faces, int64_t m, const float *corner_uvs, int has_uvs,
                const int64_t *side, const int64_t *vertex, const double *t, int64_t p,
                const npy_bool *chosen, const npy_bool *split, Split s, int64_t *out, float *uvs,
                int64_t *source, int64_t *rest_side, int64_t *rest_vertex, double *rest_t) {
    int64_t kept = m - s.groups, n = s.chosen, r = p - n;
    int64_t *first_fan = malloc((size_t)(s.groups + 1) * sizeof(int64_t));
    int64_t *side_corner = malloc((size_t)(s.groups + 1) * sizeof(int64_t));
    int64_t *moved = malloc((size_t)(r + 1) * sizeof(int64_t));
    int64_t *vertex_of = malloc((size_t)(r + 1) * sizeof(int64_t));
    double *t_of = malloc((size_t)(r + 1) * sizeof(double));
    int64_t *order = malloc((size_t)(r + 1) * sizeof(int64_t));
    int64_t *spare = malloc((size_t)(r + 1) * sizeof(int64_t));
    int status = -1;
    if (first_fan == NULL || side_corner == NULL || moved == NULL || vertex_of == NULL ||
        t_of == NULL || order == NULL || spare == NULL)
        goto done;
    int64_t row = 0;
    for (int64_t f = 0; f < m; f++) {
        if (split[f]) continue;
        for (int corner = 0; corner < 3; corner++) {
            out[3 * row + corner] = faces[3 * f + corner];
            if (has_uvs) {
                uvs[6 * row + 2 * corner] = corner_uvs[6 * f + 2 * corner];
                uvs[6 * row + 2 * corner + 1] = corner_uvs[6 * f + 2 * corner + 1];
            }
        }
        source[row++] = f;
    }
    /* Per split face (ascending), its first fan face and its chosen side's corner i. */
    int64_t group = -1, last_row = kept + n, previous = 0;
    double at_previous[2] = {0.0, 0.0}, at[2] = {0.0, 0.0};
    for (int64_t j = 0; j < p; j++) {
        if (!chosen[j]) continue;
        int64_t f = side[j] / 3, i = side[j] % 3;
        int64_t a = faces[3 * f + i], b = faces[3 * f + (i + 1) % 3], c = faces[3 * f + (i + 2) % 3];
        int first = j == 0 || side[j - 1] != side[j] || !chosen[j - 1];
        if (first) {
            group++;
            first_fan[group] = row;
            side_corner[group] = i;
            previous = a;
        }
        out[3 * row] = previous;
        out[3 * row + 1] = vertex[j];
        out[3 * row + 2] = c;
        source[row] = f;
        int last = j == p - 1 || side[j + 1] != side[j];
        if (last) {
            out[3 * last_row] = vertex[j];
            out[3 * last_row + 1] = b;
            out[3 * last_row + 2] = c;
            source[last_row] = f;
        }
        if (has_uvs) {
            const float *uv = corner_uvs + 6 * f; /* corner q's axis d at uv[2 q + d] */
            float *fan = uvs + 6 * row, *end = uvs + 6 * last_row;
            for (int d = 0; d < 2; d++) {
                double uv_a = (double)uv[2 * i + d];
                double uv_b = (double)uv[2 * ((i + 1) % 3) + d];
                at[d] = uv_a + t[j] * (uv_b - uv_a);
                if (first) at_previous[d] = uv_a;
                fan[d] = (float)at_previous[d];
                fan[2 + d] = (float)at[d];
                fan[4 + d] = uv[2 * ((i + 2) % 3) + d];
                if (last) {
                    end[d] = (float)at[d];
                    end[2 + d] = uv[2 * ((i + 1) % 3) + d];
                    end[4 + d] = uv[2 * ((i + 2) % 3) + d];
                }
                at_previous[d] = at[d];
            }
        }
        if (last) last_row++;
        previous = vertex[j];
        row++;
    }
    /* The points on other sides, moved to the fan faces holding those sides now: the first fan
     * face holds c -> a (its side 2), the last one b -> c (its side 1). */
    int64_t q = 0;
    group = -1;
    for (int64_t j = 0; j < p; j++) {
        if (j == 0 || side[j] / 3 != side[j - 1] / 3) group++;
        if (chosen[j]) continue;
        if (side[j] % 3 == (side_corner[group] + 1) % 3) moved[q] = 3 * (kept + n + group) + 1;
        else moved[q] = 3 * first_fan[group] + 2;
        vertex_of[q] = vertex[j];
        t_of[q] = t[j];
        q++;
    }
    /* Points of one side keep their order (by t): a stable sort by side is the (side, t) order. */
    const int64_t *sorted = stable_order(moved, r, order, spare);
    for (int64_t x = 0; x < r; x++) {
        rest_side[x] = moved[sorted[x]];
        rest_vertex[x] = vertex_of[sorted[x]];
        rest_t[x] = t_of[sorted[x]];
    }
    status = 0;
done:
    free(first_fan);
    free(side_corner);
    free(moved);
    free(vertex_of);
    free(t_of);
    free(order);
    free(spare);
    return status;
}

/* fans(faces (m, 3) int64, corner_uvs (m, 3, 2) float32 (read when has_uvs), has_uvs,
 * side (p,) int64 ascending, vertex (p,) int64, t (p,) float64) -> (faces (m', 3), corner_uvs
 * (m', 3, 2) float32 ((0, 3, 2) without UVs), source (m',), rest side, rest vertex, rest t). */
static PyObject *py_fans(PyObject *self, PyObject *args) {
    PyObject *faces_obj, *uvs_obj, *side_obj, *vertex_obj, *t_obj, *result = NULL;
    int has_uvs;
    const char *kernel = "split.fans";
    npy_bool *chosen = NULL, *split = NULL;
    PyArrayObject *out[6] = {NULL, NULL, NULL, NULL, NULL, NULL};
    if (!PyArg_ParseTuple(args, "OOpOOO:fans", &faces_obj, &uvs_obj, &has_uvs, &side_obj,
                          &vertex_obj, &t_obj))
        return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *corner_uvs = k_array(uvs_obj, NPY_FLOAT32, 3, 0, kernel, "corner_uvs");
    PyArrayObject *side = k_array(side_obj, NPY_INT64, 1, 0, kernel, "side");
    PyArrayObject *vertex = k_array(vertex_obj, NPY_INT64, 1, 0, kernel, "vertex");
    PyArrayObject *t = k_array(t_obj, NPY_FLOAT64, 1, 0, kernel, "t");
    if (faces == NULL || corner_uvs == NULL || side == NULL || vertex == NULL || t == NULL)
        goto done;
    npy_intp m = PyArray_DIM(faces, 0), p = PyArray_DIM(side, 0);
    if (k_dim(faces, 1, 3, kernel, "faces") ||
        (has_uvs && (k_dim(corner_uvs, 0, m, kernel, "corner_uvs") ||
                     k_dim(corner_uvs, 1, 3, kernel, "corner_uvs") ||
                     k_dim(corner_uvs, 2, 2, kernel, "corner_uvs"))) ||
        k_indices(side, 3 * (int64_t)m, kernel, "side") || k_dim(vertex, 0, p, kernel, "vertex") ||
        k_dim(t, 0, p, kernel, "t"))
        goto done;
    const int64_t *sides = K_I64(side);
    for (npy_intp j = 1; j < p; j++) {
        if (sides[j] < sides[j - 1]) {
            PyErr_Format(PyExc_ValueError, "%s: the sides are not sorted", kernel);
            goto done;
        }
    }
    Split s = {0, 0, 0};
    Py_BEGIN_ALLOW_THREADS
    chosen = calloc((size_t)p + 1, 1);
    split = calloc((size_t)m + 1, 1);
    if (chosen != NULL && split != NULL) s = choose(sides, p, chosen, split);
    Py_END_ALLOW_THREADS
    if (chosen == NULL || split == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    npy_intp total = m - s.groups + s.chosen + s.sides, rest = p - s.chosen;
    npy_intp face_dims[2] = {total, 3}, uv_dims[3] = {has_uvs ? total : 0, 3, 2};
    out[0] = k_empty(2, face_dims, NPY_INT64);
    out[1] = k_empty(3, uv_dims, NPY_FLOAT32);
    out[2] = k_empty(1, &total, NPY_INT64);
    out[3] = k_empty(1, &rest, NPY_INT64);
    out[4] = k_empty(1, &rest, NPY_INT64);
    out[5] = k_empty(1, &rest, NPY_FLOAT64);
    for (int x = 0; x < 6; x++)
        if (out[x] == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = fans(K_I64(faces), m, K_F32(corner_uvs), has_uvs, sides, K_I64(vertex), K_F64(t), p,
                  chosen, split, s, K_I64(out[0]), K_F32(out[1]), K_I64(out[2]), K_I64(out[3]),
                  K_I64(out[4]), K_F64(out[5]));
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    result = PyTuple_Pack(6, out[0], out[1], out[2], out[3], out[4], out[5]);
done:
    free(chosen);
    free(split);
    Py_XDECREF(faces);
    Py_XDECREF(corner_uvs);
    Py_XDECREF(side);
    Py_XDECREF(vertex);
    Py_XDECREF(t);
    for (int x = 0; x < 6; x++) Py_XDECREF(out[x]);
    return result;
}

static PyMethodDef methods[] = {
    {"fans", py_fans, METH_VARARGS,
     "fans(faces, corner_uvs, has_uvs, side, vertex, t) -> (faces, corner_uvs, source, rest "
     "side, rest vertex, rest t): every face split into a fan at the points on its lowest side"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(split, "Faces split into fans at the points on one of their sides (slits.split_sides).",
         methods)
