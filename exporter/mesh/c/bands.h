/* Bands of a chain difference: the cycles of each region's difference between the boundary chains
 * of two triangulations of one flat polygon, and each cycle's width when it is a band (step 4 of
 * exporter/mesh/coverage.py). Shared by band.c (the module exporter.mesh._band) and region.c (the
 * region certificate, which calls region_bands).
 *
 * A cycle is walked edge after edge; where several edges leave a vertex the walk turns onto the
 * other side's edge (two bands meeting at a corner); an ambiguous turn, a walk that does not close
 * or one longer than max_edges makes the region's cycles unknown. A closed cycle is a band when,
 * split at its two farthest-apart vertices (the first such pair in (p, q) order), it is two runs
 * each monotone along that chord (within 1e-12 of its length), one of the level's boundary edges
 * (side +1) and the other of the source's (side -1); its width is the spread of the vertices
 * across the chord. Every float operation is the one the former numpy form did, in its order (the
 * chord length is pow(b, half) with half = 0.5 given at run time, as Python's b ** 0.5: sqrt
 * differs in the last bit for ~1 in 1,000 values), so widths are the same bits (checked in
 * tests/test_band_kernels.py against a plain reference). In-plane metres.
 *
 * Data form: rows r of a chain difference, edge a[r] -> b[r] (vertex ids) with side[r] (+1 the
 * level's, -1 the source's, 0 both), sorted by region (stable); by_start the rows sorted by
 * (region, a, row), so the rows leaving a vertex within a region are a range in row order.
 */
#ifndef EXPORTER_MESH_BANDS_H
#define EXPORTER_MESH_BANDS_H

#include "kernels.h"
#include "sorted.h"

/* Cycles of rows lo..hi-1 (a_sorted[t] = a[by_start[t]]; by_start[lo:hi] within [lo, hi)):
 * fills cycle_of (cycle number per row) and order_in_cycle; returns the cycle count, or -1 when a
 * walk fails. used (npy_bool) and options are scratch of hi - lo entries. */
static int64_t band_walk(const int64_t *a, const int64_t *b, const int64_t *side,
                         const int64_t *by_start, const int64_t *a_sorted, int64_t lo, int64_t hi,
                         int64_t max_edges, int64_t *cycle_of, int64_t *order_in_cycle,
                         npy_bool *used, int64_t *options) {
    (void)a;
    int64_t n = hi - lo, cycles = 0;
    memset(used, 0, (size_t)n * sizeof(npy_bool));
    for (int64_t first = 0; first < n; first++) {
        if (used[first]) continue;
        int64_t i = first, count = 0;
        for (;;) {
            used[i] = 1;
            cycle_of[lo + i] = cycles;
            order_in_cycle[lo + i] = count;
            count++;
            if (count > max_edges) return -1;
            int64_t end = b[lo + i];
            int64_t s = lower_bound(a_sorted, lo, hi, end);
            int64_t e = upper_bound(a_sorted, lo, hi, end);
            if (e - s == 1) {
                int64_t j = by_start[s] - lo;
                if (j == first) break;
                if (used[j]) return -1;
                i = j;
                continue;
            }
            /* Leaving rows in row order (the stable sort keeps it), not used or the first. */
            int found_first = 0;
            int64_t k = 0;
            for (int64_t t = s; t < e; t++) {
                int64_t j = by_start[t] - lo;
                if (j == first) found_first = 1;
                if (!used[j] || j == first) options[k++] = j;
            }
            if (found_first) break;
            if (k > 1) {
                int64_t m = 0;
                for (int64_t t = 0; t < k; t++)
                    if (side[lo + options[t]] != side[lo + i]) options[m++] = options[t];
                k = m;
            }
            if (k != 1) return -1;
            i = options[0];
        }
        cycles++;
    }
    return cycles;
}

/* Width (metres) across the chord of one cycle (vertex e at (x[e], y[e]), edge e from vertex e to
 * e + 1 cyclically, side per edge), NaN when it is not a band. */
static double band_width(const double *x, const double *y, const int64_t *side, int64_t n,
                         double half) {
    double best = -1.0;
    int64_t p = 0, q = 0;
    for (int64_t i = 0; i < n; i++) {
        for (int64_t j = i + 1; j < n; j++) {
            double dx = x[j] - x[i];
            double dy = y[j] - y[i];
            double d = dx * dx + dy * dy;
            if (d > best) {
                best = d;
                p = i;
                q = j;
            }
        }
    }
    if (!(best > 0.0)) return NAN;
    double length = pow(best, half);
    double xi = x[p], yi = y[p];
    double ax = (x[q] - x[p]) / length;
    double ay = (y[q] - y[p]) / length;
    double slack = 1e-12 * length;
    int first_pos = 1, first_neg = 1, second_pos = 1, second_neg = 1;
    double high = -INFINITY, low = INFINITY;
    for (int64_t e = 0; e < n; e++) {
        int64_t nxt = e + 1 < n ? e + 1 : 0;
        double t = (x[e] - xi) * ax + (y[e] - yi) * ay;
        double t_next = (x[nxt] - xi) * ax + (y[nxt] - yi) * ay;
        double step = t_next - t;
        double h = (y[e] - yi) * ax - (x[e] - xi) * ay;
        high = k_max(high, h);
        low = k_min(low, h);
        if (p <= e && e < q) {
            if (step < -slack) return NAN;
            first_pos &= side[e] == 1;
            first_neg &= side[e] == -1;
        } else {
            if (-step < -slack) return NAN;
            second_pos &= side[e] == 1;
            second_neg &= side[e] == -1;
        }
    }
    if (!((first_pos && second_neg) || (first_neg && second_pos))) return NAN;
    return high - low;
}

/* For the d rows of a chain difference (region, a, b, side, by_start as above; xy (d, 2) each
 * row's start vertex in its region's plane, metres): marks not good every region whose cycles are
 * not all bands and raises width (metres) to each region's widest band. 0, or -1 when out of
 * memory (nothing set; callable without the GIL). */
static int region_bands(const int64_t *region, const int64_t *a, const int64_t *b,
                        const int64_t *side, const int64_t *by_start, const double *xy, int64_t d,
                        npy_bool *good, double *width, int64_t max_edges, double half) {
    size_t n = d > 0 ? (size_t)d : 1;
    int64_t *a_sorted = malloc(n * sizeof(int64_t));
    int64_t *cycle_of = malloc(n * sizeof(int64_t));
    int64_t *order_in_cycle = malloc(n * sizeof(int64_t));
    int64_t *options = malloc(n * sizeof(int64_t));
    int64_t *sides = malloc(n * sizeof(int64_t));
    double *x = malloc(n * sizeof(double));
    double *y = malloc(n * sizeof(double));
    npy_bool *used = malloc(n * sizeof(npy_bool));
    int status = -1;
    if (!a_sorted || !cycle_of || !order_in_cycle || !options || !sides || !x || !y || !used)
        goto done;
    for (int64_t r = 0; r < d; r++) a_sorted[r] = a[by_start[r]];
    int64_t s = 0;
    while (s < d) {
        int64_t g = region[s];
        int64_t e = s;
        while (e < d && region[e] == g) e++;
        if (good[g]) {
            int64_t cycles = band_walk(a, b, side, by_start, a_sorted, s, e, max_edges, cycle_of,
                                       order_in_cycle, used, options);
            int zero = 0;
            for (int64_t r = s; r < e; r++) zero |= side[r] == 0;
            if (cycles < 0 || zero) {
                good[g] = 0;
            } else {
                for (int64_t c = 0; c < cycles; c++) {
                    int64_t size = 0;
                    for (int64_t r = s; r < e; r++) {
                        if (cycle_of[r] == c) {
                            int64_t k = order_in_cycle[r];
                            x[k] = xy[2 * r];
                            y[k] = xy[2 * r + 1];
                            sides[k] = side[r];
                            size++;
                        }
                    }
                    double band = band_width(x, y, sides, size, half);
                    if (band != band) good[g] = 0; /* NaN: not a band */
                    else if (band > width[g]) width[g] = band;
                }
            }
        }
        s = e;
    }
    status = 0;
done:
    free(a_sorted);
    free(cycle_of);
    free(order_in_cycle);
    free(options);
    free(sides);
    free(x);
    free(y);
    free(used);
    return status;
}

#endif
