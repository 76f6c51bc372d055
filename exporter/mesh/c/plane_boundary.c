/* The boundary edges of a mesh's planar regions, split at T-junctions (the certified Hausdorff
 * bound's in-plane step: exporter/mesh/hausdorff.py, _Regions._boundary).
 *
 * A half-edge is interior when its face keeps its orientation projected on the region's plane
 * and it and its opposite half-edge each occur exactly once among such half-edges of the region;
 * every other half-edge is a boundary edge. Unmatched half-edges of upright faces ("loose") are
 * first split at the region's loose vertices lying on them (strictly between the ends, within
 * `tjunction` x the edge's length of its line); `gap` is the largest such offset per region. The
 * pieces are matched again among themselves; the unmatched ones are boundary edges.
 *
 * Data form: faces (m, 3) int64 vertex ids below k; region (m,) int64 below r; tri2 (m, 3, 2)
 * float64 metres, each face projected on its region's plane. Output (edges in the order of the
 * numpy form: half-edge order when nothing is split, else the non-upright half-edges first, then
 * the pieces by loose half-edge and position along it): seg_region (s,) int64, seg (s, 2, 2)
 * metres, ends (s, 2) int64 vertex ids, oriented (s,) bool, gap (r,) metres. Float expressions
 * keep the numpy form's order (tests/test_plane_boundary_kernels.py checks the bits).
 */
#include "kernels.h"

typedef struct {
    int64_t region, a, b;
} edge_key;

static int key_cmp(const void *x, const void *y) {
    const edge_key *p = x, *q = y;
    if (p->region != q->region) return p->region < q->region ? -1 : 1;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    if (p->b != q->b) return p->b < q->b ? -1 : 1;
    return 0;
}

/* How often `key` occurs in the sorted keys[0:n]. */
static npy_intp key_count(const edge_key *keys, npy_intp n, edge_key key) {
    npy_intp lo = 0, hi = n;
    while (lo < hi) {
        npy_intp mid = lo + (hi - lo) / 2;
        if (key_cmp(&keys[mid], &key) < 0) lo = mid + 1; else hi = mid;
    }
    npy_intp end = lo;
    while (end < n && key_cmp(&keys[end], &key) == 0) end++;
    return end - lo;
}

/* matched[i]: ok[i] (NULL: all) and (region, a, b) and (region, b, a) each occur once among the
 * ok edges. -1 when out of memory. */
static int match(npy_intp n, const int64_t *region, const int64_t *a, const int64_t *b,
                 const npy_bool *ok, npy_bool *matched) {
    edge_key *keys = malloc((n > 0 ? n : 1) * sizeof(edge_key));
    if (keys == NULL) return -1;
    npy_intp count = 0;
    for (npy_intp i = 0; i < n; i++)
        if (ok == NULL || ok[i]) keys[count++] = (edge_key){region[i], a[i], b[i]};
    qsort(keys, count, sizeof(edge_key), key_cmp);
    for (npy_intp i = 0; i < n; i++) {
        matched[i] = (ok == NULL || ok[i]) &&
                     key_count(keys, count, (edge_key){region[i], a[i], b[i]}) == 1 &&
                     key_count(keys, count, (edge_key){region[i], b[i], a[i]}) == 1;
    }
    free(keys);
    return 0;
}

typedef struct {
    int64_t region, vertex, source; /* source: the first loose end naming it (starts, then ends) */
    double x, y;
} loose_end;

static int end_cmp(const void *x, const void *y) {
    const loose_end *p = x, *q = y;
    if (p->region != q->region) return p->region < q->region ? -1 : 1;
    if (p->vertex != q->vertex) return p->vertex < q->vertex ? -1 : 1;
    if (p->source != q->source) return p->source < q->source ? -1 : 1;
    return 0;
}

typedef struct {
    double along, x, y;
    int64_t vertex;
} split_point;

/* The boundary edges found: seg_region, seg (x0, y0, x1, y1), ends (a, b), oriented. */
typedef struct {
    int64_t *region, *ends;
    double *seg;
    npy_bool *oriented;
    npy_intp count;
} edge_list;

static void put(edge_list *out, int64_t region, double x0, double y0, double x1, double y1,
                int64_t a, int64_t b, npy_bool oriented) {
    npy_intp s = out->count++;
    out->region[s] = region;
    out->seg[4 * s] = x0;
    out->seg[4 * s + 1] = y0;
    out->seg[4 * s + 2] = x1;
    out->seg[4 * s + 3] = y1;
    out->ends[2 * s] = a;
    out->ends[2 * s + 1] = b;
    out->oriented[s] = oriented;
}

/* Room for n edges in `out`: 0, or -1 when out of memory (freed by the caller). */
static int reserve(edge_list *out, npy_intp n) {
    n = n > 0 ? n : 1;
    out->region = malloc(n * sizeof(int64_t));
    out->ends = malloc(2 * n * sizeof(int64_t));
    out->seg = malloc(4 * n * sizeof(double));
    out->oriented = malloc(n);
    return out->region == NULL || out->ends == NULL || out->seg == NULL || out->oriented == NULL
               ? -1
               : 0;
}

/* The work without the GIL: 0, or -1 when out of memory. Half-edge i is corner i % 3 of face
 * i / 3 to the next corner. */
static int find(npy_intp m, const int64_t *faces, const int64_t *face_region, npy_intp r,
                const double *t, double tjunction, double *gap, edge_list *out) {
    npy_intp h = 3 * m, n_loose = 0, n_ends = 0, n_sub = 0, n_split = 0, cap_split = 16;
    int status = -1;
    int64_t *a = malloc((h + 1) * sizeof(int64_t)), *b = malloc((h + 1) * sizeof(int64_t));
    int64_t *region = malloc((h + 1) * sizeof(int64_t)), *loose = malloc((h + 1) * sizeof(int64_t));
    npy_bool *upright = malloc(h + 1), *interior = malloc(h + 1);
    loose_end *ends = malloc((2 * h + 1) * sizeof(loose_end));
    npy_intp *first = malloc((r + 2) * sizeof(npy_intp));
    split_point *split = malloc(cap_split * sizeof(split_point));
    /* Pieces: at most one per loose half-edge plus one per split point (grown below). */
    npy_intp cap_sub = h + 1;
    int64_t *sub_a = NULL, *sub_b = NULL, *sub_region = NULL;
    double *sub_seg = NULL;
    npy_bool *sub_ok = NULL;
    if (a == NULL || b == NULL || region == NULL || loose == NULL || upright == NULL ||
        interior == NULL || ends == NULL || first == NULL || split == NULL)
        goto done;
    for (npy_intp f = 0; f < m; f++) {
        const double *u = t + 6 * f;
        double area2 = (u[2] - u[0]) * (u[5] - u[1]) - (u[3] - u[1]) * (u[4] - u[0]);
        for (int c = 0; c < 3; c++) {
            a[3 * f + c] = faces[3 * f + c];
            b[3 * f + c] = faces[3 * f + (c + 1) % 3];
            region[3 * f + c] = face_region[f];
            upright[3 * f + c] = area2 > 0;
        }
    }
    if (match(h, region, a, b, upright, interior)) goto done;
    for (npy_intp i = 0; i < h; i++)
        if (!interior[i] && upright[i]) loose[n_loose++] = i;
    /* The loose ends of each region, one per (region, vertex): its first point. */
    for (npy_intp j = 0; j < 2 * n_loose; j++) {
        npy_intp e = loose[j % n_loose], f = e / 3, c = e % 3, corner = j < n_loose ? c : (c + 1) % 3;
        ends[j] = (loose_end){region[e], j < n_loose ? a[e] : b[e], j, t[6 * f + 2 * corner],
                              t[6 * f + 2 * corner + 1]};
    }
    qsort(ends, 2 * n_loose, sizeof(loose_end), end_cmp);
    for (npy_intp j = 0; j < 2 * n_loose; j++)
        if (n_ends == 0 || ends[j].region != ends[n_ends - 1].region ||
            ends[j].vertex != ends[n_ends - 1].vertex)
            ends[n_ends++] = ends[j];
    for (npy_intp g = 0, j = 0; g <= r; g++) {
        while (j < n_ends && ends[j].region < g) j++;
        first[g] = j;
    }
    sub_a = malloc(cap_sub * sizeof(int64_t));
    sub_b = malloc(cap_sub * sizeof(int64_t));
    sub_region = malloc(cap_sub * sizeof(int64_t));
    sub_seg = malloc(4 * cap_sub * sizeof(double));
    if (sub_a == NULL || sub_b == NULL || sub_region == NULL || sub_seg == NULL) goto done;
    for (npy_intp l = 0; l < n_loose; l++) {
        npy_intp e = loose[l], f = e / 3, c = e % 3, g = region[e];
        double px = t[6 * f + 2 * c], py = t[6 * f + 2 * c + 1];
        double qx = t[6 * f + 2 * ((c + 1) % 3)], qy = t[6 * f + 2 * ((c + 1) % 3) + 1];
        double dx = qx - px, dy = qy - py;
        double length2 = dx * dx + dy * dy;
        npy_intp count = 0;
        for (npy_intp w = first[g]; w < first[g + 1]; w++) {
            double wx = ends[w].x - px, wy = ends[w].y - py;
            double along = (wx * dx + wy * dy) / length2;
            double off = fabs(dx * wy - dy * wx) / sqrt(length2);
            if (ends[w].vertex == a[e] || ends[w].vertex == b[e] || !(along > 0) || !(along < 1) ||
                !(off <= tjunction * sqrt(length2)))
                continue;
            if (off > gap[g]) gap[g] = off;
            if (count == cap_split) {
                split_point *grown = realloc(split, 2 * cap_split * sizeof(split_point));
                if (grown == NULL) goto done;
                split = grown;
                cap_split *= 2;
            }
            /* Stable insertion by position along the edge. */
            npy_intp at = count++;
            while (at > 0 && split[at - 1].along > along) {
                split[at] = split[at - 1];
                at--;
            }
            split[at] = (split_point){along, ends[w].x, ends[w].y, ends[w].vertex};
        }
        n_split += count;
        if (n_sub + count + 1 > cap_sub) {
            npy_intp grow = 2 * (n_sub + count + 1);
            int64_t *na = realloc(sub_a, grow * sizeof(int64_t));
            if (na != NULL) sub_a = na;
            int64_t *nb = realloc(sub_b, grow * sizeof(int64_t));
            if (nb != NULL) sub_b = nb;
            int64_t *nr = realloc(sub_region, grow * sizeof(int64_t));
            if (nr != NULL) sub_region = nr;
            double *ns = realloc(sub_seg, 4 * grow * sizeof(double));
            if (ns != NULL) sub_seg = ns;
            if (na == NULL || nb == NULL || nr == NULL || ns == NULL) goto done;
            cap_sub = grow;
        }
        int64_t from = a[e];
        double fx = px, fy = py;
        for (npy_intp s = 0; s <= count; s++) {
            int64_t to = s < count ? split[s].vertex : b[e];
            double tx = s < count ? split[s].x : qx, ty = s < count ? split[s].y : qy;
            sub_a[n_sub] = from;
            sub_b[n_sub] = to;
            sub_region[n_sub] = g;
            sub_seg[4 * n_sub] = fx;
            sub_seg[4 * n_sub + 1] = fy;
            sub_seg[4 * n_sub + 2] = tx;
            sub_seg[4 * n_sub + 3] = ty;
            n_sub++;
            from = to;
            fx = tx;
            fy = ty;
        }
    }
    if (n_split == 0) { /* nothing split: the unmatched half-edges in order */
        if (reserve(out, h)) goto done;
        for (npy_intp i = 0; i < h; i++) {
            if (interior[i]) continue;
            npy_intp f = i / 3, c = i % 3, d = (c + 1) % 3;
            put(out, region[i], t[6 * f + 2 * c], t[6 * f + 2 * c + 1], t[6 * f + 2 * d],
                t[6 * f + 2 * d + 1], a[i], b[i], upright[i]);
        }
        status = 0;
        goto done;
    }
    sub_ok = malloc(n_sub + 1);
    if (sub_ok == NULL || match(n_sub, sub_region, sub_a, sub_b, NULL, sub_ok) ||
        reserve(out, h + n_sub))
        goto done;
    for (npy_intp i = 0; i < h; i++) {
        if (interior[i] || upright[i]) continue;
        npy_intp f = i / 3, c = i % 3, d = (c + 1) % 3;
        put(out, region[i], t[6 * f + 2 * c], t[6 * f + 2 * c + 1], t[6 * f + 2 * d],
            t[6 * f + 2 * d + 1], a[i], b[i], 0);
    }
    for (npy_intp s = 0; s < n_sub; s++) {
        if (sub_ok[s]) continue;
        put(out, sub_region[s], sub_seg[4 * s], sub_seg[4 * s + 1], sub_seg[4 * s + 2],
            sub_seg[4 * s + 3], sub_a[s], sub_b[s], 1);
    }
    status = 0;
done:
    free(a);
    free(b);
    free(region);
    free(loose);
    free(upright);
    free(interior);
    free(ends);
    free(first);
    free(split);
    free(sub_a);
    free(sub_b);
    free(sub_region);
    free(sub_seg);
    free(sub_ok);
    return status;
}

/* boundary(faces (m, 3) int64, k, region (m,) int64, r, tri2 (m, 3, 2) float64, tjunction) ->
 * (seg_region (s,), seg (s, 2, 2), ends (s, 2), oriented (s,) bool, gap (r,)). */
static PyObject *boundary(PyObject *self, PyObject *args) {
    PyObject *faces_obj, *region_obj, *tri_obj, *result = NULL;
    Py_ssize_t k, r;
    double tjunction;
    const char *kernel = "plane_boundary.boundary";
    PyArrayObject *gap = NULL, *out_region = NULL, *out_seg = NULL, *out_ends = NULL,
                  *out_oriented = NULL;
    edge_list edges = {NULL, NULL, NULL, NULL, 0};
    if (!PyArg_ParseTuple(args, "OnOnOd:boundary", &faces_obj, &k, &region_obj, &r, &tri_obj,
                          &tjunction))
        return NULL;
    PyArrayObject *faces = k_array(faces_obj, NPY_INT64, 2, 0, kernel, "faces");
    PyArrayObject *region = k_array(region_obj, NPY_INT64, 1, 0, kernel, "region");
    PyArrayObject *tri = k_array(tri_obj, NPY_FLOAT64, 3, 0, kernel, "tri2");
    if (faces == NULL || region == NULL || tri == NULL) goto done;
    npy_intp m = PyArray_DIM(faces, 0);
    if (k_dim(faces, 1, 3, kernel, "faces") || k_dim(region, 0, m, kernel, "region") ||
        k_dim(tri, 0, m, kernel, "tri2") || k_dim(tri, 1, 3, kernel, "tri2") ||
        k_dim(tri, 2, 2, kernel, "tri2") || k_indices(faces, k, kernel, "faces") ||
        k_indices(region, r, kernel, "region"))
        goto done;
    npy_intp dims_r[1] = {r};
    gap = k_zeros(1, dims_r, NPY_FLOAT64);
    if (gap == NULL) goto done;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = find(m, K_I64(faces), K_I64(region), r, K_F64(tri), tjunction, K_F64(gap), &edges);
    Py_END_ALLOW_THREADS
    if (status) {
        PyErr_NoMemory();
        goto done;
    }
    npy_intp s = edges.count;
    npy_intp d1[1] = {s}, d2[2] = {s, 2}, d3[3] = {s, 2, 2};
    out_region = k_empty(1, d1, NPY_INT64);
    out_seg = k_empty(3, d3, NPY_FLOAT64);
    out_ends = k_empty(2, d2, NPY_INT64);
    out_oriented = k_empty(1, d1, NPY_BOOL);
    if (out_region == NULL || out_seg == NULL || out_ends == NULL || out_oriented == NULL) goto done;
    if (s) {
        memcpy(K_I64(out_region), edges.region, s * sizeof(int64_t));
        memcpy(K_F64(out_seg), edges.seg, 4 * s * sizeof(double));
        memcpy(K_I64(out_ends), edges.ends, 2 * s * sizeof(int64_t));
        memcpy(K_BOOL(out_oriented), edges.oriented, s);
    }
    result = Py_BuildValue("(NNNNN)", out_region, out_seg, out_ends, out_oriented, gap);
    out_region = out_seg = out_ends = out_oriented = gap = NULL;
done:
    free(edges.region);
    free(edges.ends);
    free(edges.seg);
    free(edges.oriented);
    Py_XDECREF(faces);
    Py_XDECREF(region);
    Py_XDECREF(tri);
    Py_XDECREF(gap);
    Py_XDECREF(out_region);
    Py_XDECREF(out_seg);
    Py_XDECREF(out_ends);
    Py_XDECREF(out_oriented);
    return result;
}

static PyMethodDef methods[] = {
    {"boundary", boundary, METH_VARARGS,
     "boundary(faces, k, region, r, tri2, tjunction) -> (seg_region, seg, ends, oriented, gap)"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(plane_boundary, "Boundary edges of planar regions, split at T-junctions.", methods)
