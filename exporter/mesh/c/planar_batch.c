/* The integer bookkeeping and the exact float sums of the planar stage's batched
 * retriangulation (exporter.simplify.planar: region_setup and _retriangulate_many).
 *
 * - sums: per region the outward normal sum of its faces' cross products, (b - a) x (c - a)
 *   added row after row onto 0.0 (cross_rows and the former planar._region_sums, operation for
 *   operation).
 * - uvs: per region one UV per vertex (the first corner's in face order) and whether any corner
 *   of a vertex has another UV (!= compared, so a NaN differs); keys region * k + vertex.
 * - rings: the outline loops of some regions with the droppable vertices removed, flat, with
 *   every ring vertex's predecessor in its ring; a region with a loop under 3 vertices fails.
 * - outline: earcut's triangles as vertex ids, and per region whether the edges used once are
 *   exactly its rings' edges and none is used more than twice.
 * - plane / basis: areas, unit normals and plane axes of the normal sums (the dot products,
 *   which numpy may do in BLAS, stay numpy calls between them).
 * - spans / held: vertices of one region, faces by region, regions holding a droppable vertex.
 * - finish / uv_lookup: the new faces' cross products, orientation and area checks, UVs.
 * - border_length: the open boundary's length with np.sum's pairwise arithmetic.
 * - straight: unlocked vertices on exactly two outline edges that run straight through them.
 * Data: positions (k, 3) float64 metres (building-local East/Up/North), faces int64 ids below k.
 * The former numpy and Python form is kept in tests/test_planar_batch_kernels.py as reference.
 */
#include "faces.h"
#include "sorted.h"

/* 0 when the region sizes (faces per region, (count,) int64) sum to f, else -1 with a
 * ValueError. */
static int check_sizes(PyArrayObject *sizes, npy_intp f, const char *kernel) {
    int64_t total = 0;
    for (npy_intp r = 0; r < PyArray_DIM(sizes, 0); r++) total += K_I64(sizes)[r];
    if (total == f) return 0;
    PyErr_Format(PyExc_ValueError, "%s: sizes sum to %lld, not %zd faces", kernel,
                 (long long)total, (Py_ssize_t)f);
    return -1;
}

/* sums(positions (k, 3) float64, faces (f, 3) int64, sizes (count,) int64 summing to f)
 * -> (count, 3) float64 normal sums. */
static PyObject *sums(PyObject *self, PyObject *args) {
    PyObject *positions_obj, *faces_obj, *sizes_obj;
    const char *kernel = "planar_batch.sums";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOO:sums", &positions_obj, &faces_obj, &sizes_obj)) return NULL;
    PyArrayObject *positions = k_array(positions_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *sizes = k_array(sizes_obj, NPY_INT64, 1, 0, kernel, "sizes");
    if (positions == NULL || faces == NULL || sizes == NULL) goto done;
    npy_intp k = PyArray_DIM(positions, 0), f = PyArray_DIM(faces, 0);
    npy_intp count = PyArray_DIM(sizes, 0), dims[2] = {count, 3};
    if (k_dim(positions, 1, 3, kernel, "positions") || k_dim(faces, 1, 3, kernel, "faces") ||
        k_indices(faces, k, kernel, "faces") || k_indices(sizes, f + 1, kernel, "sizes"))
        goto done;
    if (check_sizes(sizes, f, kernel)) goto done;
    out = k_empty(2, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    Py_BEGIN_ALLOW_THREADS
    const double *p = K_F64(positions);
    const int64_t *face = K_I64(faces), *size = K_I64(sizes);
    double *normal = K_F64(out);
    int64_t at = 0;
    for (npy_intp r = 0; r < count; r++) {
        double sx = 0.0, sy = 0.0, sz = 0.0;
        for (int64_t e = at + size[r]; at < e; at++) {
            double n[3];
            face_cross(p, face + 3 * at, n);
            sx += n[0];
            sy += n[1];
            sz += n[2];
        }
        normal[3 * r] = sx;
        normal[3 * r + 1] = sy;
        normal[3 * r + 2] = sz;
    }
    Py_END_ALLOW_THREADS
done:
    Py_XDECREF(positions);
    Py_XDECREF(faces);
    Py_XDECREF(sizes);
    return (PyObject *)out;
}

/* The uv pass over regions of faces (f, 3) with corner uvs (f, 3, 2) float32; sizes (count,)
 * faces per region. Fills keys (3 f), values (3 f, 2), bad (count) and returns the key count,
 * or -1 when scratch memory is lacking. */
static int64_t uv_pass(const int64_t *face, const float *uv, const int64_t *size, int64_t count,
                       int64_t f, int64_t k, int64_t *keys, float *values, npy_bool *bad) {
    int64_t *order = malloc((size_t)(3 * f + 1) * sizeof(int64_t));
    int64_t *spare = malloc((size_t)(3 * f + 1) * sizeof(int64_t));
    int64_t written = 0, at = 0;
    if (order == NULL || spare == NULL) {
        written = -1;
        goto done;
    }
    for (int64_t r = 0; r < count; r++) {
        const int64_t *corner = face + 3 * at; /* the region's 3 size[r] corners, face order */
        const float *corner_uv = uv + 6 * at;
        int64_t n = 3 * size[r];
        int64_t *sorted = stable_order(corner, n, order, spare);
        bad[r] = 0;
        for (int64_t i = 0; i < n; i++) {
            int64_t c = sorted[i];
            if (i == 0 || corner[c] != corner[sorted[i - 1]]) {
                keys[written] = r * k + corner[c];
                values[2 * written] = corner_uv[2 * c];
                values[2 * written + 1] = corner_uv[2 * c + 1];
                written++;
            } else {
                int64_t b = sorted[i - 1];
                if (corner_uv[2 * c] != corner_uv[2 * b] ||
                    corner_uv[2 * c + 1] != corner_uv[2 * b + 1])
                    bad[r] = 1;
            }
        }
        at += size[r];
    }
done:
    free(order);
    free(spare);
    return written;
}

/* uvs(faces (f, 3) int64, corner_uvs (f, 3, 2) float32, sizes (count,) int64, k) ->
 * (keys (3 f,) int64, values (3 f, 2) float32, bad (count,) bool, n): the first n keys and
 * values hold the ascending keys region * k + vertex and each one's first corner UV. */
static PyObject *uvs(PyObject *self, PyObject *args) {
    PyObject *faces_obj, *uv_obj, *sizes_obj, *result = NULL;
    long long k;
    const char *kernel = "planar_batch.uvs";
    PyArrayObject *keys = NULL, *values = NULL, *bad = NULL;
    if (!PyArg_ParseTuple(args, "OOOL:uvs", &faces_obj, &uv_obj, &sizes_obj, &k)) return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *corner_uvs = k_array(uv_obj, NPY_FLOAT32, 3, 0, kernel, "corner_uvs");
    PyArrayObject *sizes = k_array(sizes_obj, NPY_INT64, 1, 0, kernel, "sizes");
    if (faces == NULL || corner_uvs == NULL || sizes == NULL) goto done;
    npy_intp f = PyArray_DIM(faces, 0), count = PyArray_DIM(sizes, 0);
    npy_intp n3 = 3 * f, dims[2] = {3 * f, 2};
    if (k < 0 || k_dim(faces, 1, 3, kernel, "faces") || k_indices(faces, k, kernel, "faces") ||
        k_dim(corner_uvs, 0, f, kernel, "corner_uvs") ||
        k_dim(corner_uvs, 1, 3, kernel, "corner_uvs") ||
        k_dim(corner_uvs, 2, 2, kernel, "corner_uvs") || k_indices(sizes, f + 1, kernel, "sizes"))
        goto done;
    if (check_sizes(sizes, f, kernel)) goto done;
    keys = k_empty(1, &n3, NPY_INT64);
    values = k_empty(2, dims, NPY_FLOAT32);
    bad = k_empty(1, &count, NPY_BOOL);
    if (keys == NULL || values == NULL || bad == NULL) goto done;
    int64_t written;
    Py_BEGIN_ALLOW_THREADS
    written = uv_pass(K_I64(faces), K_F32(corner_uvs), K_I64(sizes), count, f, k, K_I64(keys),
                      K_F32(values), K_BOOL(bad));
    Py_END_ALLOW_THREADS
    if (written < 0) {
        PyErr_NoMemory();
        goto done;
    }
    result = Py_BuildValue("(OOOL)", keys, values, bad, (long long)written);
done:
    Py_XDECREF(faces);
    Py_XDECREF(corner_uvs);
    Py_XDECREF(sizes);
    Py_XDECREF(keys);
    Py_XDECREF(values);
    Py_XDECREF(bad);
    return result;
}

/* rings(loop_vertices (v,) int64, loop_bounds (l + 1,) int64, region_loops (s + 1,) int64,
 * setup_ok (s,) bool, ids (count,) int64 below s, droppable (k,) bool) -> (ok (count,) bool,
 * ring_vertices (n,), previous (n,), ring_ends (rings,), region_rings (t + 1,), todo (t,),
 * ring_sizes (rings,) uint32 (earcut's ends of a one-ring region)):
 * region ids[j]'s loops are loop_bounds[region_loops[i]:region_loops[i + 1] + 1] slices of
 * loop_vertices; ok: setup_ok and every loop keeps 3 vertices; the ok regions' (todo, ascending)
 * kept ring vertices in order, each one's predecessor (index into ring_vertices), the rings'
 * cumulative ends and the first ring of each todo region (ring indices). */
static PyObject *rings(PyObject *self, PyObject *args) {
    PyObject *v_obj, *b_obj, *r_obj, *ok_obj, *ids_obj, *drop_obj, *result = NULL;
    const char *kernel = "planar_batch.rings";
    PyArrayObject *ok = NULL, *ring_vertices = NULL, *previous = NULL, *ring_ends = NULL,
                  *region_rings = NULL, *todo = NULL, *ring_sizes = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOO:rings", &v_obj, &b_obj, &r_obj, &ok_obj, &ids_obj,
                          &drop_obj))
        return NULL;
    PyArrayObject *loop_vertices = k_array(v_obj, NPY_INT64, 1, 0, kernel, "loop_vertices");
    PyArrayObject *loop_bounds = k_array(b_obj, NPY_INT64, 1, 0, kernel, "loop_bounds");
    PyArrayObject *region_loops = k_array(r_obj, NPY_INT64, 1, 0, kernel, "region_loops");
    PyArrayObject *setup_ok = k_array(ok_obj, NPY_BOOL, 1, 0, kernel, "setup_ok");
    PyArrayObject *ids = k_array(ids_obj, NPY_INT64, 1, 0, kernel, "ids");
    PyArrayObject *droppable = k_array(drop_obj, NPY_BOOL, 1, 0, kernel, "droppable");
    if (loop_vertices == NULL || loop_bounds == NULL || region_loops == NULL ||
        setup_ok == NULL || ids == NULL || droppable == NULL)
        goto done;
    npy_intp nv = PyArray_DIM(loop_vertices, 0), nl = PyArray_DIM(loop_bounds, 0) - 1;
    npy_intp s = PyArray_DIM(setup_ok, 0), count = PyArray_DIM(ids, 0);
    npy_intp k = PyArray_DIM(droppable, 0);
    const int64_t *lv = K_I64(loop_vertices), *lb = K_I64(loop_bounds), *rl = K_I64(region_loops);
    if (nl < 0 || k_dim(region_loops, 0, s + 1, kernel, "region_loops") ||
        k_indices(ids, s, kernel, "ids") || k_indices(loop_vertices, k, kernel, "loop_vertices") ||
        k_indices(loop_bounds, nv + 1, kernel, "loop_bounds") ||
        k_indices(region_loops, nl + 1, kernel, "region_loops"))
        goto done;
    for (npy_intp i = 0; i < nl; i++) {
        if (lb[i] > lb[i + 1]) {
            PyErr_Format(PyExc_ValueError, "%s: loop_bounds are not ascending", kernel);
            goto done;
        }
    }
    for (npy_intp i = 0; i < s; i++) {
        if (rl[i] > rl[i + 1]) {
            PyErr_Format(PyExc_ValueError, "%s: region_loops are not ascending", kernel);
            goto done;
        }
    }
    const npy_bool *drop = K_BOOL(droppable), *sok = K_BOOL(setup_ok);
    const int64_t *id = K_I64(ids);
    ok = k_empty(1, &count, NPY_BOOL);
    if (ok == NULL) goto done;
    npy_bool *good = K_BOOL(ok);
    /* First pass: which regions are ok and the output sizes. */
    npy_intp n = 0, ring_count = 0, t = 0;
    for (npy_intp j = 0; j < count; j++) {
        int64_t i = id[j];
        good[j] = sok[i];
        if (!good[j]) continue;
        npy_intp kept_total = 0;
        for (int64_t l = rl[i]; l < rl[i + 1]; l++) {
            npy_intp kept = 0;
            for (int64_t x = lb[l]; x < lb[l + 1]; x++) kept += !drop[lv[x]];
            if (kept < 3) good[j] = 0;
            kept_total += kept;
        }
        if (good[j]) {
            n += kept_total;
            ring_count += rl[i + 1] - rl[i];
            t++;
        }
    }
    npy_intp t1 = t + 1;
    ring_vertices = k_empty(1, &n, NPY_INT64);
    previous = k_empty(1, &n, NPY_INT64);
    ring_ends = k_empty(1, &ring_count, NPY_INT64);
    ring_sizes = k_empty(1, &ring_count, NPY_UINT32);
    region_rings = k_empty(1, &t1, NPY_INT64);
    todo = k_empty(1, &t, NPY_INT64);
    if (ring_vertices == NULL || previous == NULL || ring_ends == NULL || region_rings == NULL ||
        todo == NULL || ring_sizes == NULL)
        goto done;
    Py_BEGIN_ALLOW_THREADS
    int64_t *rv = K_I64(ring_vertices), *prev = K_I64(previous), *ends = K_I64(ring_ends);
    int64_t *first_ring = K_I64(region_rings), *todo_out = K_I64(todo);
    uint32_t *ring_size = (uint32_t *)PyArray_DATA(ring_sizes);
    int64_t at = 0, ring = 0, slot = 0;
    for (npy_intp j = 0; j < count; j++) {
        if (!good[j]) continue;
        int64_t i = id[j];
        todo_out[slot] = j;
        first_ring[slot++] = ring;
        for (int64_t l = rl[i]; l < rl[i + 1]; l++) {
            int64_t start = at;
            for (int64_t x = lb[l]; x < lb[l + 1]; x++) {
                if (drop[lv[x]]) continue;
                rv[at] = lv[x];
                prev[at] = at - 1;
                at++;
            }
            prev[start] = at - 1;
            ring_size[ring] = (uint32_t)(at - start);
            ends[ring++] = at;
        }
    }
    first_ring[slot] = ring;
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("(OOOOOOO)", ok, ring_vertices, previous, ring_ends, region_rings, todo,
                           ring_sizes);
done:
    Py_XDECREF(loop_vertices);
    Py_XDECREF(loop_bounds);
    Py_XDECREF(region_loops);
    Py_XDECREF(setup_ok);
    Py_XDECREF(ids);
    Py_XDECREF(droppable);
    Py_XDECREF(ok);
    Py_XDECREF(ring_vertices);
    Py_XDECREF(previous);
    Py_XDECREF(ring_ends);
    Py_XDECREF(region_rings);
    Py_XDECREF(todo);
    Py_XDECREF(ring_sizes);
    return result;
}

static int key_less(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* The outline check of `regions` regions; returns -1 when scratch memory is lacking. */
static int outline_pass(const int64_t *tri, const int64_t *offset, const int64_t *size,
                        const int64_t *face_count, int64_t regions, const int64_t *rv,
                        const int64_t *prev, int64_t k, int64_t *new_faces, npy_bool *bad) {
    int64_t longest = 0;
    for (int64_t i = 0; i < regions; i++) {
        longest = k_imax(longest, 3 * face_count[i]);
        longest = k_imax(longest, size[i]);
    }
    int64_t *edges = malloc((size_t)(longest + 1) * sizeof(int64_t));
    int64_t *loop = malloc((size_t)(longest + 1) * sizeof(int64_t));
    if (edges == NULL || loop == NULL) {
        free(edges);
        free(loop);
        return -1;
    }
    int64_t face = 0;
    for (int64_t i = 0; i < regions; i++) {
        int64_t n = 3 * face_count[i];
        for (int64_t c = 0; c < n; c++) new_faces[3 * face + c] = rv[offset[i] + tri[3 * face + c]];
        for (int64_t g = 0; g < face_count[i]; g++) {
            const int64_t *corner = new_faces + 3 * (face + g);
            for (int c = 0; c < 3; c++) {
                int64_t a = corner[c], b = corner[(c + 1) % 3];
                edges[3 * g + c] = a < b ? a * k + b : b * k + a;
            }
        }
        qsort(edges, (size_t)n, sizeof(int64_t), key_less);
        for (int64_t x = 0; x < size[i]; x++) {
            int64_t a = rv[offset[i] + x], b = rv[prev[offset[i] + x]];
            loop[x] = a < b ? a * k + b : b * k + a;
        }
        qsort(loop, (size_t)size[i], sizeof(int64_t), key_less);
        /* Edges used once, in order, must be the loop's edges; none used three times. */
        int64_t matched = 0;
        int broken = 0;
        for (int64_t lo = 0, hi; lo < n && !broken; lo = hi) {
            hi = run_end(edges, n, lo);
            if (hi - lo > 2) broken = 1;
            if (hi - lo == 1) broken |= matched >= size[i] || loop[matched++] != edges[lo];
        }
        bad[i] = (npy_bool)(broken || matched != size[i]);
        face += face_count[i];
    }
    free(edges);
    free(loop);
    return 0;
}

/* outline(tris (3 F,) int64, offsets (d,), sizes (d,), face_counts (d,) int64, ring_vertices
 * (n,), previous (n,) int64, k) -> (new_faces (F, 3) int64, bad (d,) bool): region i's
 * face_counts[i] triangles index ring_vertices[offsets[i]:offsets[i] + sizes[i]]. */
static PyObject *outline(PyObject *self, PyObject *args) {
    PyObject *t_obj, *o_obj, *s_obj, *c_obj, *v_obj, *p_obj, *result = NULL;
    long long k;
    const char *kernel = "planar_batch.outline";
    PyArrayObject *new_faces = NULL, *bad = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOOL:outline", &t_obj, &o_obj, &s_obj, &c_obj, &v_obj,
                          &p_obj, &k))
        return NULL;
    PyArrayObject *tris = k_array(t_obj, NPY_INT64, 1, 0, kernel, "tris");
    PyArrayObject *offsets = k_array(o_obj, NPY_INT64, 1, 0, kernel, "offsets");
    PyArrayObject *sizes = k_array(s_obj, NPY_INT64, 1, 0, kernel, "sizes");
    PyArrayObject *counts = k_array(c_obj, NPY_INT64, 1, 0, kernel, "face_counts");
    PyArrayObject *ring_vertices = k_array(v_obj, NPY_INT64, 1, 0, kernel, "ring_vertices");
    PyArrayObject *previous = k_array(p_obj, NPY_INT64, 1, 0, kernel, "previous");
    if (tris == NULL || offsets == NULL || sizes == NULL || counts == NULL ||
        ring_vertices == NULL || previous == NULL)
        goto done;
    npy_intp d = PyArray_DIM(offsets, 0), n = PyArray_DIM(ring_vertices, 0);
    npy_intp nt = PyArray_DIM(tris, 0);
    if (k <= 0 || k > 3037000499LL || k_dim(sizes, 0, d, kernel, "sizes") ||
        k_dim(counts, 0, d, kernel, "face_counts") ||
        k_dim(previous, 0, n, kernel, "previous") || k_indices(previous, n, kernel, "previous") ||
        k_indices(ring_vertices, k, kernel, "ring_vertices") ||
        k_indices(offsets, n + 1, kernel, "offsets") || k_indices(sizes, n + 1, kernel, "sizes") ||
        k_indices(counts, nt / 3 + 1, kernel, "face_counts"))
        goto done;
    const int64_t *off = K_I64(offsets), *size = K_I64(sizes), *cnt = K_I64(counts);
    const int64_t *tri = K_I64(tris);
    npy_intp faces_total = 0;
    for (npy_intp i = 0; i < d; i++) {
        if (off[i] + size[i] > n) {
            PyErr_Format(PyExc_ValueError, "%s: region %zd runs past ring_vertices", kernel, i);
            goto done;
        }
        for (int64_t c = 3 * faces_total; c < 3 * (faces_total + cnt[i]) && c < nt; c++) {
            if (tri[c] < 0 || tri[c] >= size[i]) {
                PyErr_Format(PyExc_ValueError, "%s: tris holds %lld, outside region %zd", kernel,
                             (long long)tri[c], i);
                goto done;
            }
        }
        faces_total += cnt[i];
    }
    if (3 * faces_total != nt) {
        PyErr_Format(PyExc_ValueError, "%s: face_counts sum to %zd, tris has %zd", kernel,
                     (Py_ssize_t)faces_total, (Py_ssize_t)nt);
        goto done;
    }
    npy_intp dims[2] = {faces_total, 3};
    new_faces = k_empty(2, dims, NPY_INT64);
    bad = k_empty(1, &d, NPY_BOOL);
    if (new_faces == NULL || bad == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = outline_pass(tri, off, size, cnt, d, K_I64(ring_vertices), K_I64(previous), k,
                          K_I64(new_faces), K_BOOL(bad));
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    result = Py_BuildValue("(OO)", new_faces, bad);
done:
    Py_XDECREF(tris);
    Py_XDECREF(offsets);
    Py_XDECREF(sizes);
    Py_XDECREF(counts);
    Py_XDECREF(ring_vertices);
    Py_XDECREF(previous);
    Py_XDECREF(new_faces);
    Py_XDECREF(bad);
    return result;
}

/* The straight-vertex test over sorted edge keys; returns -1 when scratch memory is lacking. */
static int straight_pass(const int64_t *keys, const int64_t *order, int64_t n, const int64_t *regions,
                         const double *p, const npy_bool *locked, double tolerance, int on_border,
                         int64_t k, npy_bool *straight) {
    int64_t *degree = calloc((size_t)(k + 1), sizeof(int64_t));
    int64_t *neighbour = malloc((size_t)(2 * k + 1) * sizeof(int64_t)); /* first two, in order */
    npy_bool *border = calloc((size_t)(k + 1), 1);
    if (degree == NULL || neighbour == NULL || border == NULL) {
        free(degree);
        free(neighbour);
        free(border);
        return -1;
    }
    /* The outline half-edges by source, stable: every outline edge from its low end (edges
     * ascending), then every one from its high end. */
    for (int side = 0; side < 2; side++) {
        for (int64_t lo = 0, hi; lo < n; lo = hi) {
            hi = run_end(keys, n, lo);
            int64_t low = keys[lo] / k, high = keys[lo] % k;
            int64_t least = regions[order[lo] / 3], most = least;
            for (int64_t e = lo + 1; e < hi; e++) {
                least = k_imin(least, regions[order[e] / 3]);
                most = k_imax(most, regions[order[e] / 3]);
            }
            if (side == 0 && hi - lo == 1) border[low] = border[high] = 1;
            if (hi - lo != 1 && least == most) continue;
            int64_t source = side == 0 ? low : high, target = side == 0 ? high : low;
            if (degree[source] < 2) neighbour[2 * source + degree[source]] = target;
            degree[source]++;
        }
    }
    for (int64_t v = 0; v < k; v++) {
        straight[v] = 0;
        if (degree[v] != 2 || locked[v] || (!on_border && border[v])) continue;
        int64_t left = neighbour[2 * v], right = neighbour[2 * v + 1];
        const double *a = p + 3 * left, *b = p + 3 * right, *q = p + 3 * v;
        double d0 = b[0] - a[0], d1 = b[1] - a[1], d2 = b[2] - a[2];
        double w0 = q[0] - a[0], w1 = q[1] - a[1], w2 = q[2] - a[2];
        double length = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        double c0 = d1 * w2 - d2 * w1, c1 = d2 * w0 - d0 * w2, c2 = d0 * w1 - d1 * w0;
        double floor_length = isnan(length) || length >= 1e-30 ? length : 1e-30;
        double squared = length * length;
        double floor_squared = isnan(squared) || squared >= 1e-30 ? squared : 1e-30;
        double off_line = sqrt(c0 * c0 + c1 * c1 + c2 * c2) / floor_length;
        double between = (w0 * d0 + w1 * d1 + w2 * d2) / floor_squared;
        /* Not where the two neighbours already share an edge (a slit / T-junction). */
        int64_t pair = left < right ? left * k + right : right * k + left;
        int64_t at = lower_bound(keys, 0, n, pair);
        int closes = at < n && keys[at] == pair;
        straight[v] = (npy_bool)(off_line < tolerance && between > 0 && between < 1 && !closes);
    }
    free(degree);
    free(neighbour);
    free(border);
    return 0;
}

/* straight(positions (k, 3) float64, keys (3 m,) int64 ascending, order (3 m,) int64 sides,
 * regions (m,) int64, locked (k,) bool, tolerance, on_border) -> (k,) bool: planar.straight_vertices
 * (keys low * k + high of every face side, order the side each key came from). */
static PyObject *straight(PyObject *self, PyObject *args) {
    PyObject *p_obj, *keys_obj, *order_obj, *regions_obj, *locked_obj;
    double tolerance;
    int on_border;
    const char *kernel = "planar_batch.straight";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOdp:straight", &p_obj, &keys_obj, &order_obj, &regions_obj,
                          &locked_obj, &tolerance, &on_border))
        return NULL;
    PyArrayObject *positions = k_array(p_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *keys = k_array(keys_obj, NPY_INT64, 1, 0, kernel, "keys");
    PyArrayObject *order = k_array(order_obj, NPY_INT64, 1, 0, kernel, "order");
    PyArrayObject *regions = k_array(regions_obj, NPY_INT64, 1, 0, kernel, "regions");
    PyArrayObject *locked = k_array(locked_obj, NPY_BOOL, 1, 0, kernel, "locked");
    if (positions == NULL || keys == NULL || order == NULL || regions == NULL || locked == NULL)
        goto done;
    npy_intp k = PyArray_DIM(positions, 0), n = PyArray_DIM(keys, 0);
    npy_intp m = PyArray_DIM(regions, 0);
    if (k_dim(positions, 1, 3, kernel, "positions") || k_dim(locked, 0, k, kernel, "locked") ||
        k_dim(keys, 0, 3 * m, kernel, "keys") || k_dim(order, 0, n, kernel, "order") ||
        k_indices(order, n, kernel, "order") ||
        (k > 0 && k_indices(keys, (int64_t)k * k, kernel, "keys")))
        goto done;
    if (k == 0 && n > 0) {
        PyErr_Format(PyExc_ValueError, "%s: keys without vertices", kernel);
        goto done;
    }
    for (npy_intp i = 1; i < n; i++) {
        if (K_I64(keys)[i] < K_I64(keys)[i - 1]) {
            PyErr_Format(PyExc_ValueError, "%s: keys are not ascending", kernel);
            goto done;
        }
    }
    out = k_empty(1, &k, NPY_BOOL);
    if (out == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = straight_pass(K_I64(keys), K_I64(order), n, K_I64(regions), K_F64(positions),
                           K_BOOL(locked), tolerance, on_border, k, K_BOOL(out));
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        Py_CLEAR(out);
    }
done:
    Py_XDECREF(positions);
    Py_XDECREF(keys);
    Py_XDECREF(order);
    Py_XDECREF(regions);
    Py_XDECREF(locked);
    return (PyObject *)out;
}

/* plane(sums (c, 3) float64, dots (c,) float64: each sum's dot with itself) -> (area (c,),
 * normal (c, 3), u (c, 3)): area 0.5 sqrt(dot) m², the unit normal sum / (2 area) and the
 * first plane axis before its normalisation (normal x helper, helper (1, 0, 0) or (0, 1, 0)),
 * the operations of planar._plane_basis per row. */
static PyObject *plane(PyObject *self, PyObject *args) {
    PyObject *sums_obj, *dots_obj, *result = NULL;
    const char *kernel = "planar_batch.plane";
    PyArrayObject *area = NULL, *normal = NULL, *u = NULL;
    if (!PyArg_ParseTuple(args, "OO:plane", &sums_obj, &dots_obj)) return NULL;
    PyArrayObject *sums_in = k_array(sums_obj, NPY_FLOAT64, 2, 0, kernel, "sums");
    PyArrayObject *dots = k_array(dots_obj, NPY_FLOAT64, 1, 0, kernel, "dots");
    if (sums_in == NULL || dots == NULL) goto done;
    npy_intp c = PyArray_DIM(sums_in, 0), dims[2] = {c, 3};
    if (k_dim(sums_in, 1, 3, kernel, "sums") || k_dim(dots, 0, c, kernel, "dots")) goto done;
    area = k_empty(1, &c, NPY_FLOAT64);
    normal = k_empty(2, dims, NPY_FLOAT64);
    u = k_empty(2, dims, NPY_FLOAT64);
    if (area == NULL || normal == NULL || u == NULL) goto done;
    Py_BEGIN_ALLOW_THREADS
    const double *sum = K_F64(sums_in), *dot = K_F64(dots);
    double *a = K_F64(area), *nrm = K_F64(normal), *axis = K_F64(u);
    for (npy_intp r = 0; r < c; r++) {
        a[r] = 0.5 * sqrt(dot[r]);
        double twice = 2 * a[r];
        double x = sum[3 * r] / twice, y = sum[3 * r + 1] / twice, z = sum[3 * r + 2] / twice;
        double hx = fabs(x) < 0.9 ? 1.0 : 0.0, hy = 1.0 - hx;
        nrm[3 * r] = x;
        nrm[3 * r + 1] = y;
        nrm[3 * r + 2] = z;
        axis[3 * r] = y * 0.0 - z * hy;
        axis[3 * r + 1] = z * hx - x * 0.0;
        axis[3 * r + 2] = x * hy - y * hx;
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("(OOO)", area, normal, u);
done:
    Py_XDECREF(sums_in);
    Py_XDECREF(dots);
    Py_XDECREF(area);
    Py_XDECREF(normal);
    Py_XDECREF(u);
    return result;
}

/* basis(normal (c, 3), u (c, 3), dots (c,): each u's dot with itself) -> (c, 3, 2): the plane
 * axes u / sqrt(dot) and normal x that as columns. */
static PyObject *basis(PyObject *self, PyObject *args) {
    PyObject *normal_obj, *u_obj, *dots_obj;
    const char *kernel = "planar_batch.basis";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOO:basis", &normal_obj, &u_obj, &dots_obj)) return NULL;
    PyArrayObject *normal = k_array(normal_obj, NPY_FLOAT64, 2, 0, kernel, "normal");
    PyArrayObject *u = k_array(u_obj, NPY_FLOAT64, 2, 0, kernel, "u");
    PyArrayObject *dots = k_array(dots_obj, NPY_FLOAT64, 1, 0, kernel, "dots");
    if (normal == NULL || u == NULL || dots == NULL) goto done;
    npy_intp c = PyArray_DIM(normal, 0), dims[3] = {c, 3, 2};
    if (k_dim(normal, 1, 3, kernel, "normal") || k_dim(u, 0, c, kernel, "u") ||
        k_dim(u, 1, 3, kernel, "u") || k_dim(dots, 0, c, kernel, "dots"))
        goto done;
    out = k_empty(3, dims, NPY_FLOAT64);
    if (out == NULL) goto done;
    Py_BEGIN_ALLOW_THREADS
    const double *n = K_F64(normal), *axis = K_F64(u), *dot = K_F64(dots);
    double *b = K_F64(out);
    for (npy_intp r = 0; r < c; r++) {
        double length = sqrt(dot[r]);
        double x = n[3 * r], y = n[3 * r + 1], z = n[3 * r + 2];
        double u0 = axis[3 * r] / length, u1 = axis[3 * r + 1] / length,
               u2 = axis[3 * r + 2] / length;
        b[6 * r] = u0;
        b[6 * r + 2] = u1;
        b[6 * r + 4] = u2;
        b[6 * r + 1] = y * u2 - z * u1;
        b[6 * r + 3] = z * u0 - x * u2;
        b[6 * r + 5] = x * u1 - y * u0;
    }
    Py_END_ALLOW_THREADS
done:
    Py_XDECREF(normal);
    Py_XDECREF(u);
    Py_XDECREF(dots);
    return (PyObject *)out;
}

/* spans(faces (m, 3) int64, regions (m,) int64 in [0, count), count, k) -> (one_region (k,)
 * bool, used (k,) bool, by_region (m,) int64, region_start (count + 1,) int64): the vertices
 * used by faces of one region only, the vertices used at all, the faces in stable region order
 * and where each region's faces start in it. */
static PyObject *spans(PyObject *self, PyObject *args) {
    PyObject *faces_obj, *regions_obj, *result = NULL;
    long long count, k;
    const char *kernel = "planar_batch.spans";
    PyArrayObject *one = NULL, *used = NULL, *by_region = NULL, *region_start = NULL;
    if (!PyArg_ParseTuple(args, "OOLL:spans", &faces_obj, &regions_obj, &count, &k)) return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *regions = k_array(regions_obj, NPY_INT64, 1, 0, kernel, "regions");
    if (faces == NULL || regions == NULL) goto done;
    npy_intp m = PyArray_DIM(faces, 0), kk = (npy_intp)k, c1 = (npy_intp)count + 1;
    if (k < 0 || count < 0 || k_dim(faces, 1, 3, kernel, "faces") ||
        k_indices(faces, k, kernel, "faces") || k_dim(regions, 0, m, kernel, "regions") ||
        k_indices(regions, count, kernel, "regions"))
        goto done;
    one = k_empty(1, &kk, NPY_BOOL);
    used = k_zeros(1, &kk, NPY_BOOL);
    by_region = k_empty(1, &m, NPY_INT64);
    region_start = k_zeros(1, &c1, NPY_INT64);
    if (one == NULL || used == NULL || by_region == NULL || region_start == NULL) goto done;
    int64_t *first = malloc((size_t)(k + 1) * sizeof(int64_t)); /* each vertex's first region */
    int64_t *slot = malloc((size_t)(count + 1) * sizeof(int64_t)); /* each region's next slot */
    if (first == NULL || slot == NULL) {
        free(first);
        free(slot);
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    const int64_t *face = K_I64(faces), *region = K_I64(regions);
    npy_bool *single = K_BOOL(one), *in_use = K_BOOL(used);
    int64_t *start = K_I64(region_start), *sorted = K_I64(by_region);
    for (int64_t v = 0; v < k; v++) single[v] = 1;
    for (npy_intp f = 0; f < m; f++) {
        for (int c = 0; c < 3; c++) {
            int64_t v = face[3 * f + c];
            if (!in_use[v]) {
                in_use[v] = 1;
                first[v] = region[f];
            } else if (first[v] != region[f]) {
                single[v] = 0;
            }
        }
        start[region[f] + 1]++;
    }
    for (int64_t v = 0; v < k; v++) single[v] &= in_use[v];
    for (int64_t r = 0; r < count; r++) start[r + 1] += start[r];
    /* Counting sort by region: stable, as np.argsort(kind="stable"). */
    for (int64_t r = 0; r < count; r++) slot[r] = start[r];
    for (npy_intp f = 0; f < m; f++) sorted[slot[region[f]]++] = f;
    Py_END_ALLOW_THREADS
    free(first);
    free(slot);
    result = Py_BuildValue("(OOOO)", one, used, by_region, region_start);
done:
    Py_XDECREF(faces);
    Py_XDECREF(regions);
    Py_XDECREF(one);
    Py_XDECREF(used);
    Py_XDECREF(by_region);
    Py_XDECREF(region_start);
    return result;
}

/* held(droppable (k,) bool, faces (m, 3) int64 in region order, region_start (count + 1,)
 * int64 ascending) -> (count,) bool: whether region r's faces hold a droppable vertex
 * (np.logical_or.reduceat of the faces' any, so an empty region gives its next face's). */
static PyObject *held(PyObject *self, PyObject *args) {
    PyObject *drop_obj, *faces_obj, *start_obj;
    const char *kernel = "planar_batch.held";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOO:held", &drop_obj, &faces_obj, &start_obj)) return NULL;
    PyArrayObject *droppable = k_array(drop_obj, NPY_BOOL, 1, 0, kernel, "droppable");
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *region_start = k_array(start_obj, NPY_INT64, 1, 0, kernel, "region_start");
    if (droppable == NULL || faces == NULL || region_start == NULL) goto done;
    npy_intp m = PyArray_DIM(faces, 0), count = PyArray_DIM(region_start, 0) - 1;
    if (count < 0 || k_dim(faces, 1, 3, kernel, "faces") ||
        k_indices(faces, PyArray_DIM(droppable, 0), kernel, "faces"))
        goto done;
    const int64_t *start = K_I64(region_start);
    for (npy_intp r = 0; r < count; r++) {
        if (start[r] < 0 || start[r] > start[r + 1] || start[r + 1] > m || start[r] >= m) {
            PyErr_Format(PyExc_ValueError, "%s: region_start is not ascending within [0, %zd)",
                         kernel, (Py_ssize_t)m);
            goto done;
        }
    }
    out = k_empty(1, &count, NPY_BOOL);
    if (out == NULL) goto done;
    Py_BEGIN_ALLOW_THREADS
    const npy_bool *drop = K_BOOL(droppable);
    const int64_t *face = K_I64(faces);
    npy_bool *any = K_BOOL(out);
    for (npy_intp r = 0; r < count; r++) {
        int64_t hi = start[r + 1] > start[r] ? start[r + 1] : start[r] + 1;
        npy_bool found = 0;
        for (int64_t c = 3 * start[r]; c < 3 * hi && !found; c++) found = drop[face[c]] != 0;
        any[r] = found;
    }
    Py_END_ALLOW_THREADS
done:
    Py_XDECREF(droppable);
    Py_XDECREF(faces);
    Py_XDECREF(region_start);
    return (PyObject *)out;
}

/* numpy's pairwise summation of a[0:n] (loops_utils.h: below 8 one after the other, up to 128 in
 * eight interleaved partial sums, above that the halves at a multiple of 8), onto 0.0 as
 * np.add.reduce of a contiguous float64 array without buffering. */
static double pairwise_sum(const double *a, int64_t n) {
    if (n < 8) {
        double res = -0.0;
        for (int64_t i = 0; i < n; i++) res += a[i];
        return res;
    }
    if (n <= 128) {
        double r[8];
        int64_t i;
        for (int j = 0; j < 8; j++) r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++) r[j] += a[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += a[i];
        return res;
    }
    int64_t half = n / 2;
    half -= half % 8;
    return pairwise_sum(a, half) + pairwise_sum(a + half, n - half);
}

/* border_length(positions (k, 3) float64, edges (e, 2) int64, counts (e,) int64) -> float: the
 * summed length (metres) of the edges used once, np.linalg.norm(..., axis=1).sum() of them. */
static PyObject *border_length(PyObject *self, PyObject *args) {
    PyObject *p_obj, *e_obj, *c_obj, *result = NULL;
    const char *kernel = "planar_batch.border_length";
    if (!PyArg_ParseTuple(args, "OOO:border_length", &p_obj, &e_obj, &c_obj)) return NULL;
    PyArrayObject *positions = k_array(p_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *edges = k_array(e_obj, NPY_INT64, 2, 0, kernel, "edges");
    PyArrayObject *counts = k_array(c_obj, NPY_INT64, 1, 0, kernel, "counts");
    if (positions == NULL || edges == NULL || counts == NULL) goto done;
    npy_intp k = PyArray_DIM(positions, 0), e = PyArray_DIM(edges, 0);
    if (k_dim(positions, 1, 3, kernel, "positions") || k_dim(edges, 1, 2, kernel, "edges") ||
        k_indices(edges, k, kernel, "edges") || k_dim(counts, 0, e, kernel, "counts"))
        goto done;
    double *length = malloc((size_t)(e + 1) * sizeof(double));
    if (length == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double total;
    Py_BEGIN_ALLOW_THREADS
    const double *p = K_F64(positions);
    const int64_t *edge = K_I64(edges), *count = K_I64(counts);
    int64_t n = 0;
    for (npy_intp i = 0; i < e; i++) {
        if (count[i] != 1) continue;
        const double *a = p + 3 * edge[2 * i], *b = p + 3 * edge[2 * i + 1];
        double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
        length[n++] = sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    }
    total = 0.0 + pairwise_sum(length, n);
    Py_END_ALLOW_THREADS
    free(length);
    result = PyFloat_FromDouble(total);
done:
    Py_XDECREF(positions);
    Py_XDECREF(edges);
    Py_XDECREF(counts);
    return result;
}

/* pairwise(values (n,) float64) -> float: numpy's np.sum of them (exposed for the tests). */
static PyObject *pairwise(PyObject *self, PyObject *args) {
    PyObject *v_obj, *result = NULL;
    if (!PyArg_ParseTuple(args, "O:pairwise", &v_obj)) return NULL;
    PyArrayObject *values = k_array(v_obj, NPY_FLOAT64, 1, 0, "planar_batch.pairwise", "values");
    if (values == NULL) return NULL;
    result = PyFloat_FromDouble(0.0 + pairwise_sum(K_F64(values), PyArray_DIM(values, 0)));
    Py_DECREF(values);
    return result;
}

/* finish(positions (k, 3) float64, new_faces (F, 3) int64, face_counts (d,) int64, normal
 * (d, 3) float64 unit, total (d,) float64 m²) -> (n (F, 3), flip (F,) bool, bad (d,) bool,
 * recheck (d,) bool): every new face's cross product (b - a) x (c - a); whether its dot with
 * its region's normal is negative; a region is bad when its faces' areas (|n| / 2) do not sum
 * to total within 1e-6 max(total, 1) (np.sum's arithmetic: where numpy's reduceat could differ
 * in the last bits the comparison is far from its edge) or its smallest is below
 * 1e-9 max(total, 1); recheck: a face of the region almost edge-on (|dot| <= 1e-12 area), whose
 * sign the caller takes from numpy's matmul as the one-region reference does. */
static PyObject *finish(PyObject *self, PyObject *args) {
    PyObject *p_obj, *f_obj, *c_obj, *n_obj, *t_obj, *result = NULL;
    const char *kernel = "planar_batch.finish";
    PyArrayObject *cross = NULL, *flip = NULL, *bad = NULL, *recheck = NULL;
    double *areas = NULL;
    if (!PyArg_ParseTuple(args, "OOOOO:finish", &p_obj, &f_obj, &c_obj, &n_obj, &t_obj))
        return NULL;
    PyArrayObject *positions = k_array(p_obj, NPY_FLOAT64, 2, 0, kernel, "positions");
    PyArrayObject *new_faces = k_array(f_obj, NPY_INT64, 2, 0, kernel, "new_faces");
    PyArrayObject *counts = k_array(c_obj, NPY_INT64, 1, 0, kernel, "face_counts");
    PyArrayObject *normal = k_array(n_obj, NPY_FLOAT64, 2, 0, kernel, "normal");
    PyArrayObject *total = k_array(t_obj, NPY_FLOAT64, 1, 0, kernel, "total");
    if (positions == NULL || new_faces == NULL || counts == NULL || normal == NULL ||
        total == NULL)
        goto done;
    npy_intp k = PyArray_DIM(positions, 0), f = PyArray_DIM(new_faces, 0);
    npy_intp d = PyArray_DIM(counts, 0), dims[2] = {f, 3};
    if (k_dim(positions, 1, 3, kernel, "positions") ||
        k_dim(new_faces, 1, 3, kernel, "new_faces") ||
        k_indices(new_faces, k, kernel, "new_faces") || k_dim(normal, 0, d, kernel, "normal") ||
        k_dim(normal, 1, 3, kernel, "normal") || k_dim(total, 0, d, kernel, "total") ||
        k_indices(counts, f + 1, kernel, "face_counts"))
        goto done;
    if (check_sizes(counts, f, kernel)) goto done;
    cross = k_empty(2, dims, NPY_FLOAT64);
    flip = k_empty(1, &f, NPY_BOOL);
    bad = k_empty(1, &d, NPY_BOOL);
    recheck = k_empty(1, &d, NPY_BOOL);
    areas = malloc((size_t)(f + 1) * sizeof(double));
    if (cross == NULL || flip == NULL || bad == NULL || recheck == NULL) goto done;
    if (areas == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    const double *p = K_F64(positions), *unit = K_F64(normal), *want = K_F64(total);
    const int64_t *face = K_I64(new_faces), *count = K_I64(counts);
    double *n = K_F64(cross);
    npy_bool *reverse = K_BOOL(flip), *broken = K_BOOL(bad), *again = K_BOOL(recheck);
    int64_t at = 0;
    for (npy_intp i = 0; i < d; i++) {
        double smallest = 0.0;
        int nan = 0;
        again[i] = 0;
        for (int64_t g = at; g < at + count[i]; g++) {
            face_cross(p, face + 3 * g, n + 3 * g);
            double nx = n[3 * g], ny = n[3 * g + 1], nz = n[3 * g + 2];
            areas[g] = 0.5 * sqrt(nx * nx + ny * ny + nz * nz);
            /* np.minimum: a NaN wins. */
            if (isnan(areas[g])) nan = 1;
            else if (g == at || areas[g] < smallest) smallest = areas[g];
            double dot = nx * unit[3 * i] + ny * unit[3 * i + 1] + nz * unit[3 * i + 2];
            reverse[g] = dot < 0;
            again[i] |= fabs(dot) <= 1e-12 * areas[g];
        }
        double scale = np_maximum(want[i], 1.0);
        double off = fabs((0.0 + pairwise_sum(areas + at, count[i])) - want[i]) - 1e-6 * scale;
        broken[i] = (npy_bool)(off > 0 || (!nan && count[i] > 0 && smallest < 1e-9 * scale));
        at += count[i];
    }
    Py_END_ALLOW_THREADS
    result = Py_BuildValue("(OOOO)", cross, flip, bad, recheck);
done:
    free(areas);
    Py_XDECREF(positions);
    Py_XDECREF(new_faces);
    Py_XDECREF(counts);
    Py_XDECREF(normal);
    Py_XDECREF(total);
    Py_XDECREF(cross);
    Py_XDECREF(flip);
    Py_XDECREF(bad);
    Py_XDECREF(recheck);
    return result;
}

/* uv_lookup(keys (c,) int64 ascending, values (c, 2) float32, region (d,) int64, face_counts
 * (d,) int64, faces (F, 3) int64, k) -> (F, 3, 2) float32: each corner's UV, the value at
 * np.searchsorted(keys, region * k + vertex) (a key past the end is a ValueError). */
static PyObject *uv_lookup(PyObject *self, PyObject *args) {
    PyObject *k_obj, *v_obj, *r_obj, *c_obj, *f_obj;
    long long k;
    const char *kernel = "planar_batch.uv_lookup";
    PyArrayObject *out = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOL:uv_lookup", &k_obj, &v_obj, &r_obj, &c_obj, &f_obj, &k))
        return NULL;
    PyArrayObject *keys = k_array(k_obj, NPY_INT64, 1, 0, kernel, "keys");
    PyArrayObject *values = k_array(v_obj, NPY_FLOAT32, 2, 0, kernel, "values");
    PyArrayObject *region = k_array(r_obj, NPY_INT64, 1, 0, kernel, "region");
    PyArrayObject *counts = k_array(c_obj, NPY_INT64, 1, 0, kernel, "face_counts");
    PyArrayObject *faces = k_array(f_obj, NPY_INT64, 2, 0, kernel, "faces");
    if (keys == NULL || values == NULL || region == NULL || counts == NULL || faces == NULL)
        goto done;
    npy_intp c = PyArray_DIM(keys, 0), d = PyArray_DIM(region, 0), f = PyArray_DIM(faces, 0);
    npy_intp dims[3] = {f, 3, 2};
    if (k_dim(values, 0, c, kernel, "values") || k_dim(values, 1, 2, kernel, "values") ||
        k_dim(counts, 0, d, kernel, "face_counts") || k_dim(faces, 1, 3, kernel, "faces") ||
        k_indices(counts, f + 1, kernel, "face_counts"))
        goto done;
    const int64_t *key = K_I64(keys), *reg = K_I64(region), *count = K_I64(counts);
    const int64_t *face = K_I64(faces);
    if (check_sizes(counts, f, kernel)) goto done;
    out = k_empty(3, dims, NPY_FLOAT32);
    if (out == NULL) goto done;
    int past = 0;
    Py_BEGIN_ALLOW_THREADS
    const float *uv = K_F32(values);
    float *o = K_F32(out);
    int64_t at = 0;
    for (npy_intp i = 0; i < d && !past; i++) {
        for (int64_t g = at; g < at + count[i] && !past; g++) {
            for (int corner = 0; corner < 3; corner++) {
                int64_t slot = lower_bound(key, 0, c, reg[i] * k + face[3 * g + corner]);
                if (slot >= c) {
                    past = 1;
                    break;
                }
                o[6 * g + 2 * corner] = uv[2 * slot];
                o[6 * g + 2 * corner + 1] = uv[2 * slot + 1];
            }
        }
        at += count[i];
    }
    Py_END_ALLOW_THREADS
    if (past) {
        PyErr_Format(PyExc_ValueError, "%s: a corner's key is past the keys", kernel);
        Py_CLEAR(out);
    }
done:
    Py_XDECREF(keys);
    Py_XDECREF(values);
    Py_XDECREF(region);
    Py_XDECREF(counts);
    Py_XDECREF(faces);
    return (PyObject *)out;
}

static PyMethodDef methods[] = {
    {"finish", finish, METH_VARARGS, "Cross products, orientation and area checks of new faces."},
    {"uv_lookup", uv_lookup, METH_VARARGS, "Corner UVs of new faces."},
    {"border_length", border_length, METH_VARARGS, "Summed length of the edges used once."},
    {"pairwise", pairwise, METH_VARARGS, "numpy's pairwise sum."},
    {"plane", plane, METH_VARARGS, "Areas, unit normals and unnormalised first plane axes."},
    {"basis", basis, METH_VARARGS, "Plane axes as columns."},
    {"spans", spans, METH_VARARGS, "One-region and used vertices, faces by region."},
    {"held", held, METH_VARARGS, "Regions holding a droppable vertex."},
    {"straight", straight, METH_VARARGS, "Unlocked vertices on two straight outline edges."},
    {"sums", sums, METH_VARARGS, "Per-region sums of the faces' cross products."},
    {"uvs", uvs, METH_VARARGS, "Per-region first UV per vertex and UV conflicts."},
    {"rings", rings, METH_VARARGS, "Outline rings with droppable vertices removed."},
    {"outline", outline, METH_VARARGS, "Earcut triangles as vertex ids and the outline check."},
    {NULL, NULL, 0, NULL}};

K_MODULE(planar_batch, "Batched planar retriangulation bookkeeping (exporter.simplify.planar).",
         methods)
