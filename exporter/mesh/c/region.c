/* The region certificate's counting and slivers (steps 2-4 and 6 of exporter/mesh/coverage.py,
 * which holds the argument; this is its arithmetic).
 *
 * Given both meshes welded onto shared vertex ids (points (k, 3) metres, level and source faces
 * (m, 3) int64 into it), the faces not shared, and the planar regions of the source's other faces:
 * each level face joins the first region (lowest id) holding its three corners whose normal is
 * within same_normal_cos of its own; a region is refused when a face of either side flips along
 * its normal, when its chain difference has an edge of multiplicity > 1 or a cycle that is not a
 * band (bands.h), or when its bound (spread of heights + widest band + 1e-12 x the largest
 * coordinate) plus twice the weld offset exceeds max_bound. Then up to sliver_rounds rings of
 * slivers along settled edges are settled, each ring's width added.
 *
 * Every float operation is the former numpy form's, in its order: sums over three coordinates
 * left to right (.sum(1)), except the heights, which np.einsum("mkj,mj->mk") added as
 * (x + z) + y; region normals accumulated face by face (np.add.at). So the bounds and decisions
 * are the same bits (tests/test_region_kernels.py checks them against the former code).
 */
#include "bands.h"
#include "faces.h"

#define KERNEL "region.settle"

/* The inputs of one certificate (arrays C-contiguous, indices checked). */
typedef struct {
    const double *points; /* (k, 3) metres */
    int64_t k;
    const int64_t *la, *lb; /* (ma, 3), (mb, 3) level and source faces, welded ids */
    int64_t ma, mb;
    const int64_t *rest_a, *rest_b; /* (ml,), (ms,) faces not shared */
    int64_t ml, ms;
    const int64_t *region; /* (ms,) planar region of each rest_b face */
    npy_bool *done_a, *done_b; /* (ma,), (mb,) faces settled, in place */
    double offset, max_bound, scale; /* metres: weld move, bound, largest coordinate */
    double same_normal_cos, oriented_eps, half;
    int64_t max_band_edges;
    double sliver;
    int64_t sliver_rounds;
} certificate;

/* malloc of n items of `size` bytes (at least one, so an empty array is not NULL). */
static void *alloc(int64_t n, size_t size) { return malloc((n > 0 ? (size_t)n : 1) * size); }

/* table[pick] of an (n, 3) table into out (m, 3). */
static void rows_i(const int64_t *table, const int64_t *pick, int64_t m, int64_t *out) {
    for (int64_t i = 0; i < m; i++)
        for (int j = 0; j < 3; j++) out[3 * i + j] = table[3 * pick[i] + j];
}

static void rows_f(const double *table, const int64_t *pick, int64_t m, double *out) {
    for (int64_t i = 0; i < m; i++)
        for (int j = 0; j < 3; j++) out[3 * i + j] = table[3 * pick[i] + j];
}

static int any(const npy_bool *flags, int64_t n) {
    for (int64_t i = 0; i < n; i++)
        if (flags[i]) return 1;
    return 0;
}

/* Step 3: regions of faces (m, 3) that do not keep their orientation along the region's normal
 * (projected doubled area <= oriented_eps x the squared longest edge) are not good. */
static void orientation(const double *points, const int64_t *faces, int64_t m, const double *cr,
                        const int64_t *reg, const double *normals, double oriented_eps,
                        npy_bool *good) {
    for (int64_t i = 0; i < m; i++) {
        double longest = -INFINITY;
        for (int j = 0; j < 3; j++) {
            const double *p = points + 3 * faces[3 * i + j];
            const double *q = points + 3 * faces[3 * i + (j + 1) % 3];
            double e0 = p[0] - q[0], e1 = p[1] - q[1], e2 = p[2] - q[2];
            longest = k_max(longest, e0 * e0 + e1 * e1 + e2 * e2);
        }
        int64_t g = reg[i];
        double along = cr[3 * i] * normals[3 * g] + cr[3 * i + 1] * normals[3 * g + 1];
        along = along + cr[3 * i + 2] * normals[3 * g + 2];
        if (along <= oriented_eps * longest) good[g] = 0;
    }
}

/* Each region's lowest and highest corner height along its normal (einsum's order). */
static void heights(const double *points, const int64_t *faces, int64_t m, const int64_t *reg,
                    const double *normals, double *low, double *high) {
    for (int64_t i = 0; i < m; i++) {
        int64_t g = reg[i];
        for (int j = 0; j < 3; j++) {
            const double *p = points + 3 * faces[3 * i + j];
            double h = (p[0] * normals[3 * g] + p[2] * normals[3 * g + 2]) +
                       p[1] * normals[3 * g + 1];
            low[g] = k_min(low[g], h);
            high[g] = k_max(high[g], h);
        }
    }
}

/* out (ml,): the first region (lowest id) whose source faces (ms, 3) use all three corners of the
 * level face (ml, 3) and whose normal its unit normal is within same_normal_cos of; -1 if none.
 * 0, or -1 when out of memory. */
static int assign(const int64_t *level, int64_t ml, const double *normal_l, const int64_t *source,
                  int64_t ms, const int64_t *region, const double *normals, int64_t k,
                  double same_normal_cos, int64_t *out) {
    int64_t size = 3 * ms;
    int64_t *member = alloc(size, sizeof(int64_t));
    int64_t *order = alloc(size, sizeof(int64_t));
    int64_t *spare = alloc(size, sizeof(int64_t));
    int64_t *ordered = alloc(size, sizeof(int64_t));
    int64_t *start = calloc((size_t)k + 1, sizeof(int64_t));
    int64_t *fill = alloc(k, sizeof(int64_t));
    int64_t *regions_of = alloc(size, sizeof(int64_t));
    int status = -1;
    if (!member || !order || !spare || !ordered || !start || !fill || !regions_of) goto done;
    for (int64_t i = 0; i < ms; i++)
        for (int j = 0; j < 3; j++) member[3 * i + j] = region[i] * k + source[3 * i + j];
    int64_t *sorted = stable_order(member, size, order, spare);
    int64_t n = 0;
    for (int64_t t = 0; t < size; t++) { /* distinct keys, ascending (np.unique) */
        int64_t key = member[sorted[t]];
        if (n == 0 || key != ordered[n - 1]) ordered[n++] = key;
    }
    /* Regions of each vertex, ascending: a counting sort of the members by vertex. */
    for (int64_t t = 0; t < n; t++) start[ordered[t] % k + 1]++;
    for (int64_t v = 0; v < k; v++) start[v + 1] += start[v];
    memcpy(fill, start, (size_t)k * sizeof(int64_t));
    for (int64_t t = 0; t < n; t++) {
        int64_t v = ordered[t] % k;
        regions_of[fill[v]++] = ordered[t] / k;
    }
    for (int64_t f = 0; f < ml; f++) {
        out[f] = -1;
        int64_t v0 = level[3 * f];
        for (int64_t t = start[v0]; t < start[v0 + 1]; t++) {
            int64_t g = regions_of[t];
            double dot = normal_l[3 * f] * normals[3 * g] + normal_l[3 * f + 1] * normals[3 * g + 1];
            if (dot + normal_l[3 * f + 2] * normals[3 * g + 2] < same_normal_cos) continue;
            int ok = 1;
            for (int c = 1; c <= 2; c++) {
                int64_t key = g * k + level[3 * f + c];
                int64_t at = lower_bound(ordered, 0, n, key);
                ok &= at < n && ordered[at] == key;
            }
            if (ok) {
                out[f] = g;
                break;
            }
        }
    }
    status = 0;
done:
    free(member);
    free(order);
    free(spare);
    free(ordered);
    free(start);
    free(fill);
    free(regions_of);
    return status;
}

/* Steps 3-4: the nonzero edges of boundary(level faces (ml, 3)) - boundary(source faces (ms, 3))
 * per region, into rg, ra, rb, rs (3 (ml + ms) entries each) in (region, low, high) order (a -> b
 * the edge's direction in the difference, side +1 / -1 / 0: only the level's, only the
 * source's, both); regions with an edge of multiplicity above 1 are marked not good. Returns the
 * number of edges, or -1 when out of memory. */
static int64_t chain_difference(const int64_t *level, int64_t ml, const int64_t *reg_l,
                                const int64_t *source, int64_t ms, const int64_t *reg_s, int64_t k,
                                npy_bool *good, int64_t *rg, int64_t *ra, int64_t *rb,
                                int64_t *rs) {
    int64_t count = 3 * (ml + ms);
    int64_t *keys = alloc(count, sizeof(int64_t));
    int64_t *sign = alloc(count, sizeof(int64_t));
    npy_bool *from_level = alloc(count, sizeof(npy_bool));
    int64_t *order = alloc(count, sizeof(int64_t));
    int64_t *spare = alloc(count, sizeof(int64_t));
    int64_t d = -1;
    if (!keys || !sign || !from_level || !order || !spare) goto done;
    int64_t h = 0;
    for (int is_level = 1; is_level >= 0; is_level--) {
        const int64_t *faces = is_level ? level : source, *reg = is_level ? reg_l : reg_s;
        int64_t m = is_level ? ml : ms;
        for (int64_t i = 0; i < m; i++) {
            for (int j = 0; j < 3; j++) {
                int64_t a = faces[3 * i + j], b = faces[3 * i + (j + 1) % 3];
                keys[h] = (reg[i] * k + k_imin(a, b)) * k + k_imax(a, b);
                sign[h] = a < b ? 1 : -1;
                from_level[h] = (npy_bool)is_level;
                h++;
            }
        }
    }
    int64_t *sorted = stable_order(keys, count, order, spare);
    d = 0;
    int64_t i = 0;
    while (i < count) {
        int64_t key = keys[sorted[i]];
        int64_t net_l = 0, net_s = 0;
        while (i < count && keys[sorted[i]] == key) {
            if (from_level[sorted[i]]) net_l += sign[sorted[i]];
            else net_s += sign[sorted[i]];
            i++;
        }
        int64_t total = net_l - net_s;
        if (total == 0) continue;
        int64_t g = key / (k * k), low = (key / k) % k, high = key % k;
        if (total > 1 || total < -1) good[g] = 0;
        rg[d] = g;
        ra[d] = total > 0 ? low : high;
        rb[d] = total > 0 ? high : low;
        rs[d] = net_s == 0 ? 1 : (net_l == 0 ? -1 : 0);
        d++;
    }
done:
    free(keys);
    free(sign);
    free(from_level);
    free(order);
    free(spare);
    return d;
}

/* xy (d, 2) metres: each start vertex in its region's plane axes (u = n x helper, v = n x u,
 * helper x unless n is nearly x). */
static void in_plane(const int64_t *region, const int64_t *start, int64_t d, const double *points,
                     const double *normals, double *xy) {
    for (int64_t r = 0; r < d; r++) {
        const double *nn = normals + 3 * region[r];
        double n0 = nn[0], n1 = nn[1], n2 = nn[2];
        double h0 = 0.0, h1 = 1.0, h2 = 0.0;
        if (fabs(n0) < 0.9) {
            h0 = 1.0;
            h1 = 0.0;
        }
        double u0 = n1 * h2 - n2 * h1, u1 = n2 * h0 - n0 * h2, u2 = n0 * h1 - n1 * h0;
        double length = sqrt(u0 * u0 + u1 * u1 + u2 * u2);
        u0 = u0 / length;
        u1 = u1 / length;
        u2 = u2 / length;
        double v0 = n1 * u2 - n2 * u1, v1 = n2 * u0 - n0 * u2, v2 = n0 * u1 - n1 * u0;
        const double *s = points + 3 * start[r];
        xy[2 * r] = s[0] * u0 + s[1] * u1 + s[2] * u2;
        xy[2 * r + 1] = s[0] * v0 + s[1] * v1 + s[2] * v2;
    }
}

/* The region steps' scratch, all freed by regions_free. */
typedef struct {
    int64_t *fs, *fl, *reg_l, *placed, *fp, *rp, *rg, *ra, *rb, *rs, *keys, *order, *spare;
    double *cross_s, *normals, *cross_l, *normal_l, *cp, *width, *low, *high, *xy;
    npy_bool *good;
} region_scratch;

static void regions_free(region_scratch *w) {
    int64_t *ints[] = {w->fs, w->fl, w->reg_l, w->placed, w->fp, w->rp, w->rg,
                       w->ra, w->rb, w->rs,    w->keys,   w->order, w->spare};
    double *floats[] = {w->cross_s, w->normal_l, w->normals, w->cross_l, w->cp,
                        w->width,   w->low,      w->high,    w->xy};
    for (size_t i = 0; i < sizeof ints / sizeof *ints; i++) free(ints[i]);
    for (size_t i = 0; i < sizeof floats / sizeof *floats; i++) free(floats[i]);
    free(w->good);
}

/* Steps 2-4: marks the faces of regions that settle in done_a / done_b; sets *settled to the
 * largest settled region bound (metres, 0 if none). 0, or -1 when out of memory. */
static int regions(const certificate *c, double *settled) {
    region_scratch w = {0};
    const double *points = c->points;
    int64_t k = c->k, ms = c->ms, ml = c->ml;
    int status = -1;
    int64_t r = 0;
    for (int64_t i = 0; i < ms; i++) r = k_imax(r, c->region[i] + 1);
    int64_t count = 3 * (ml + ms);
    w.fs = alloc(3 * ms, sizeof(int64_t));
    w.fl = alloc(3 * ml, sizeof(int64_t));
    w.reg_l = alloc(ml, sizeof(int64_t));
    w.placed = alloc(ml, sizeof(int64_t));
    w.fp = alloc(3 * ml, sizeof(int64_t));
    w.rp = alloc(ml, sizeof(int64_t));
    w.rg = alloc(count, sizeof(int64_t));
    w.ra = alloc(count, sizeof(int64_t));
    w.rb = alloc(count, sizeof(int64_t));
    w.rs = alloc(count, sizeof(int64_t));
    w.keys = alloc(count, sizeof(int64_t));
    w.order = alloc(count, sizeof(int64_t));
    w.spare = alloc(count, sizeof(int64_t));
    w.cross_s = alloc(3 * ms, sizeof(double));
    w.normals = calloc((size_t)(3 * r), sizeof(double));
    w.cross_l = alloc(3 * ml, sizeof(double));
    w.normal_l = alloc(3 * ml, sizeof(double));
    w.cp = alloc(3 * ml, sizeof(double));
    w.width = calloc((size_t)r, sizeof(double));
    w.low = alloc(r, sizeof(double));
    w.high = alloc(r, sizeof(double));
    w.xy = alloc(2 * count, sizeof(double));
    w.good = calloc((size_t)r, sizeof(npy_bool));
    if (!w.fs || !w.fl || !w.reg_l || !w.placed || !w.fp || !w.rp || !w.rg || !w.ra || !w.rb ||
        !w.rs || !w.keys || !w.order || !w.spare || !w.cross_s || !w.normals || !w.cross_l ||
        !w.normal_l || !w.cp || !w.width || !w.low || !w.high || !w.xy || !w.good)
        goto done;
    rows_i(c->lb, c->rest_b, ms, w.fs);
    rows_i(c->la, c->rest_a, ml, w.fl);
    double *normals = w.normals;
    npy_bool *good = w.good;
    for (int64_t i = 0; i < ms; i++) {
        double *cs = w.cross_s + 3 * i;
        face_cross(points, w.fs + 3 * i, cs);
        for (int j = 0; j < 3; j++) normals[3 * c->region[i] + j] += cs[j];
    }
    for (int64_t g = 0; g < r; g++) {
        double n0 = normals[3 * g], n1 = normals[3 * g + 1], n2 = normals[3 * g + 2];
        double length = sqrt(n0 * n0 + n1 * n1 + n2 * n2);
        if (length > 0) {
            good[g] = 1;
            normals[3 * g] = n0 / length;
            normals[3 * g + 1] = n1 / length;
            normals[3 * g + 2] = n2 / length;
        } else { /* a region whose faces' normals cancel has no plane */
            normals[3 * g] = 0.0;
            normals[3 * g + 1] = 0.0;
            normals[3 * g + 2] = 1.0;
        }
    }
    for (int64_t i = 0; i < ml; i++) {
        double *cl = w.cross_l + 3 * i;
        face_cross(points, w.fl + 3 * i, cl);
        double length = k_max(sqrt(cl[0] * cl[0] + cl[1] * cl[1] + cl[2] * cl[2]), 1e-300);
        for (int j = 0; j < 3; j++) w.normal_l[3 * i + j] = cl[j] / length;
    }
    if (assign(w.fl, ml, w.normal_l, w.fs, ms, c->region, normals, k, c->same_normal_cos,
               w.reg_l))
        goto done;
    int64_t placed = 0;
    for (int64_t i = 0; i < ml; i++)
        if (w.reg_l[i] >= 0) w.placed[placed++] = i;
    rows_i(w.fl, w.placed, placed, w.fp);
    rows_f(w.cross_l, w.placed, placed, w.cp);
    for (int64_t i = 0; i < placed; i++) w.rp[i] = w.reg_l[w.placed[i]];
    orientation(points, w.fs, ms, w.cross_s, c->region, normals, c->oriented_eps, good);
    orientation(points, w.fp, placed, w.cp, w.rp, normals, c->oriented_eps, good);
    int64_t d = chain_difference(w.fp, placed, w.rp, w.fs, ms, c->region, k, good, w.rg, w.ra,
                                 w.rb, w.rs);
    if (d < 0) goto done;
    if (d) {
        for (int64_t i = 0; i < d; i++) w.keys[i] = w.rg[i] * k + w.ra[i];
        in_plane(w.rg, w.ra, d, points, normals, w.xy);
        int64_t *by_start = stable_order(w.keys, d, w.order, w.spare);
        if (region_bands(w.rg, w.ra, w.rb, w.rs, by_start, w.xy, d, good, w.width,
                         c->max_band_edges, c->half))
            goto done;
    }
    for (int64_t g = 0; g < r; g++) {
        w.low[g] = INFINITY;
        w.high[g] = -INFINITY;
    }
    heights(points, w.fs, ms, c->region, normals, w.low, w.high);
    heights(points, w.fp, placed, w.rp, normals, w.low, w.high);
    double best = 0.0;
    int found = 0;
    for (int64_t g = 0; g < r; g++) {
        double value = (w.high[g] - w.low[g]) + w.width[g] + 1e-12 * c->scale;
        good[g] &= value + 2 * c->offset <= c->max_bound;
        if (good[g]) {
            best = found ? k_max(best, value) : value;
            found = 1;
        }
    }
    for (int64_t i = 0; i < ms; i++)
        if (good[c->region[i]]) c->done_b[c->rest_b[i]] = 1;
    for (int64_t i = 0; i < placed; i++)
        if (good[w.rp[i]]) c->done_a[c->rest_a[w.placed[i]]] = 1;
    *settled = best;
    status = 0;
done:
    regions_free(&w);
    return status;
}

/* Step 6 on one side (faces (m, 3), done (m,)): marks in `marked` the open faces that are slivers
 * (twice the least altitude <= budget and <= sliver x the longest edge) whose longest edge, or
 * both other edges, are edges of done faces; sets *widest to the widest one's width (metres, 0
 * if none). 0, or -1 when out of memory. */
static int slivers(const double *points, const int64_t *faces, int64_t m, const npy_bool *done,
                   double budget, double sliver, npy_bool *marked, double *widest) {
    *widest = 0.0;
    if (budget <= 0) return 0;
    double e[3][3];
    int on[3];
    npy_bool *thin = calloc(m > 0 ? (size_t)m : 1, sizeof(npy_bool)); /* zeros */
    double *width = alloc(m, sizeof(double));
    int64_t *longest = alloc(m, sizeof(int64_t));
    int64_t *known = NULL, *order = NULL, *spare = NULL;
    int status = -1;
    if (!thin || !width || !longest) goto done;
    int any_thin = 0;
    for (int64_t i = 0; i < m; i++) {
        if (done[i]) continue;
        double top = -INFINITY;
        int at = 0;
        for (int j = 0; j < 3; j++) {
            const double *p = points + 3 * faces[3 * i + j];
            const double *q = points + 3 * faces[3 * i + (j + 1) % 3];
            for (int c = 0; c < 3; c++) e[j][c] = q[c] - p[c];
            double length = sqrt(e[j][0] * e[j][0] + e[j][1] * e[j][1] + e[j][2] * e[j][2]);
            if (length > top) {
                top = length;
                at = j;
            }
        }
        double v0 = -e[2][0], v1 = -e[2][1], v2 = -e[2][2];
        double c0 = e[0][1] * v2 - e[0][2] * v1;
        double c1 = e[0][2] * v0 - e[0][0] * v2;
        double c2 = e[0][0] * v1 - e[0][1] * v0;
        double w = 2 * sqrt(c0 * c0 + c1 * c1 + c2 * c2) / k_max(top, 1e-300);
        if (w <= budget && w <= sliver * top && top > 0) {
            thin[i] = 1;
            width[i] = w;
            longest[i] = at;
            any_thin = 1;
        }
    }
    if (!any_thin) {
        status = 0;
        goto done;
    }
    int64_t k = 0;
    for (int64_t t = 0; t < 3 * m; t++) k = k_imax(k, faces[t] + 1);
    int64_t n = 0;
    for (int64_t i = 0; i < m; i++) n += 3 * (done[i] != 0);
    known = alloc(n, sizeof(int64_t));
    order = alloc(n, sizeof(int64_t));
    spare = alloc(n, sizeof(int64_t));
    if (!known || !order || !spare) goto done;
    int64_t h = 0;
    for (int64_t i = 0; i < m; i++) {
        if (!done[i]) continue;
        for (int j = 0; j < 3; j++) {
            int64_t a = faces[3 * i + j], b = faces[3 * i + (j + 1) % 3];
            known[h++] = k_imin(a, b) * k + k_imax(a, b);
        }
    }
    int64_t *sorted = stable_order(known, n, order, spare);
    /* The keys in ascending order, into the buffer stable_order did not return. */
    int64_t *keys = sorted == order ? spare : order;
    for (int64_t t = 0; t < n; t++) keys[t] = known[sorted[t]];
    int found = 0;
    for (int64_t i = 0; i < m; i++) {
        if (!thin[i]) continue;
        for (int j = 0; j < 3; j++) {
            int64_t a = faces[3 * i + j], b = faces[3 * i + (j + 1) % 3];
            int64_t key = k_imin(a, b) * k + k_imax(a, b);
            int64_t at = lower_bound(keys, 0, n, key);
            on[j] = at < n && keys[at] == key;
        }
        int64_t j = longest[i];
        if (on[j] || (on[(j + 1) % 3] && on[(j + 2) % 3])) {
            marked[i] = 1;
            *widest = found ? k_max(*widest, width[i]) : width[i];
            found = 1;
        }
    }
    status = 0;
done:
    free(thin);
    free(width);
    free(longest);
    free(known);
    free(order);
    free(spare);
    return status;
}

/* Steps 2-4 and 6: *settled the settled bound without the weld allowance (metres); done_a and
 * done_b updated. 0, or -1 when out of memory. */
static int settle(const certificate *c, double *settled) {
    *settled = 0.0;
    if (c->ml && c->ms && regions(c, settled)) return -1;
    npy_bool *slivers_a = alloc(c->ma, sizeof(npy_bool));
    npy_bool *slivers_b = alloc(c->mb, sizeof(npy_bool));
    int status = -1;
    if (!slivers_a || !slivers_b) goto done;
    for (int64_t round = 0; round < c->sliver_rounds; round++) {
        if (!(any(c->done_a, c->ma) || any(c->done_b, c->mb))) break;
        double budget = c->max_bound - 2 * c->offset - *settled;
        memset(slivers_a, 0, c->ma > 0 ? (size_t)c->ma : 1);
        memset(slivers_b, 0, c->mb > 0 ? (size_t)c->mb : 1);
        double width_a, width_b;
        if (slivers(c->points, c->la, c->ma, c->done_a, budget, c->sliver, slivers_a, &width_a) ||
            slivers(c->points, c->lb, c->mb, c->done_b, budget, c->sliver, slivers_b, &width_b))
            goto done;
        if (!(any(slivers_a, c->ma) || any(slivers_b, c->mb))) break;
        *settled += k_max(width_a, width_b);
        for (int64_t i = 0; i < c->ma; i++) c->done_a[i] = c->done_a[i] || slivers_a[i];
        for (int64_t i = 0; i < c->mb; i++) c->done_b[i] = c->done_b[i] || slivers_b[i];
    }
    status = 0;
done:
    free(slivers_a);
    free(slivers_b);
    return status;
}

/* settle(points (k, 3) float64, level (ma, 3), source (mb, 3), rest_level (ml,), rest_source
 * (ms,), region (ms,) int64, done_level (ma,), done_source (mb,) bool, offset, max_bound, scale,
 * same_normal_cos, oriented_eps, max_band_edges, half, sliver, sliver_rounds): the settled
 * bound (metres); done_* updated in place. */
static PyObject *py_settle(PyObject *self, PyObject *args) {
    PyObject *objs[8], *result = NULL;
    PyArrayObject *arr[8] = {NULL};
    certificate c;
    long long max_band_edges, sliver_rounds;
    if (!PyArg_ParseTuple(args, "OOOOOOOOdddddLddL:settle", &objs[0], &objs[1], &objs[2],
                          &objs[3], &objs[4], &objs[5], &objs[6], &objs[7], &c.offset,
                          &c.max_bound, &c.scale, &c.same_normal_cos, &c.oriented_eps,
                          &max_band_edges, &c.half, &c.sliver, &sliver_rounds))
        return NULL;
    c.max_band_edges = max_band_edges;
    c.sliver_rounds = sliver_rounds;
    static const char *names[8] = {"points", "level", "source", "rest_level", "rest_source",
                                   "region", "done_level", "done_source"};
    arr[0] = k_array(objs[0], NPY_FLOAT64, 2, 0, KERNEL, names[0]);
    for (int i = 1; i < 6; i++) arr[i] = k_array(objs[i], NPY_INT64, i < 3 ? 2 : 1, 0, KERNEL, names[i]);
    for (int i = 6; i < 8; i++) arr[i] = k_array(objs[i], NPY_BOOL, 1, 1, KERNEL, names[i]);
    if (PyErr_Occurred()) goto done;
    c.k = PyArray_DIM(arr[0], 0);
    c.ma = PyArray_DIM(arr[1], 0);
    c.mb = PyArray_DIM(arr[2], 0);
    c.ml = PyArray_DIM(arr[3], 0);
    c.ms = PyArray_DIM(arr[4], 0);
    if (k_dim(arr[0], 1, 3, KERNEL, names[0]) || k_dim(arr[1], 1, 3, KERNEL, names[1]) ||
        k_dim(arr[2], 1, 3, KERNEL, names[2]) || k_dim(arr[5], 0, c.ms, KERNEL, names[5]) ||
        k_dim(arr[6], 0, c.ma, KERNEL, names[6]) || k_dim(arr[7], 0, c.mb, KERNEL, names[7]) ||
        k_indices(arr[1], c.k, KERNEL, names[1]) || k_indices(arr[2], c.k, KERNEL, names[2]) ||
        k_indices(arr[3], c.ma, KERNEL, names[3]) || k_indices(arr[4], c.mb, KERNEL, names[4]) ||
        k_indices(arr[5], INT64_MAX, KERNEL, names[5]))
        goto done;
    c.points = K_F64(arr[0]);
    c.la = K_I64(arr[1]);
    c.lb = K_I64(arr[2]);
    c.rest_a = K_I64(arr[3]);
    c.rest_b = K_I64(arr[4]);
    c.region = K_I64(arr[5]);
    c.done_a = K_BOOL(arr[6]);
    c.done_b = K_BOOL(arr[7]);
    double settled;
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = settle(&c, &settled);
    Py_END_ALLOW_THREADS
    if (status < 0) {
        PyErr_NoMemory();
        goto done;
    }
    result = PyFloat_FromDouble(settled);
done:
    for (int i = 0; i < 8; i++) Py_XDECREF(arr[i]);
    return result;
}

static PyMethodDef methods[] = {
    {"settle", py_settle, METH_VARARGS,
     "settle(points, level, source, rest_level, rest_source, region, done_level, done_source, "
     "offset, max_bound, scale, same_normal_cos, oriented_eps, max_band_edges, half, sliver, "
     "sliver_rounds): the settled bound (metres), done_* updated"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(region, "The region certificate's counting and slivers (steps 2-4 and 6), metres.",
         methods)
