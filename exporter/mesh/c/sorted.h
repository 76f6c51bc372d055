/* Sorted int64 keys: binary search and a stable order (a bottom-up merge sort; ties keep their
 * input order, as np.argsort(kind="stable")). Shared by the kernels that group by key. */
#ifndef EXPORTER_MESH_SORTED_H
#define EXPORTER_MESH_SORTED_H

#include <stdint.h>

/* First index in keys[lo:hi] (ascending) whose value is >= key (hi if none). */
static inline int64_t lower_bound(const int64_t *keys, int64_t lo, int64_t hi, int64_t key) {
    while (lo < hi) {
        int64_t mid = (lo + hi) >> 1;
        if (keys[mid] < key) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* First index in keys[lo:hi] (ascending) whose value is > key (hi if none). */
static inline int64_t upper_bound(const int64_t *keys, int64_t lo, int64_t hi, int64_t key) {
    while (lo < hi) {
        int64_t mid = (lo + hi) >> 1;
        if (keys[mid] <= key) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* The end of the run of values equal to keys[lo] starting at lo (n if it reaches the end). */
static inline int64_t run_end(const int64_t *keys, int64_t n, int64_t lo) {
    int64_t hi = lo;
    while (hi < n && keys[hi] == keys[lo]) hi++;
    return hi;
}

/* A bottom-up merge sort of `order` (n int64 indices, filled with 0..n-1), `spare` (n) as
 * scratch: LE(a, b) says whether index a may stay before index b (ties keep their input order
 * when it is a <=). Leaves the result in `order` (the two pointers swap as the passes go). */
#define K_STABLE_ORDER(n, order, spare, LE)                                                     \
    do {                                                                                        \
        for (int64_t i_ = 0; i_ < (n); i_++) (order)[i_] = i_;                                  \
        for (int64_t width = 1; width < (n); width *= 2) {                                      \
            for (int64_t lo = 0; lo < (n); lo += 2 * width) {                                   \
                int64_t mid = lo + width < (n) ? lo + width : (n);                              \
                int64_t hi = lo + 2 * width < (n) ? lo + 2 * width : (n);                       \
                int64_t i = lo, j = mid;                                                        \
                for (int64_t t = lo; t < hi; t++) {                                             \
                    if (i < mid && (j >= hi || LE((order)[i], (order)[j])))                     \
                        (spare)[t] = (order)[i++];                                              \
                    else                                                                        \
                        (spare)[t] = (order)[j++];                                              \
                }                                                                               \
            }                                                                                   \
            int64_t *swap = (order);                                                            \
            (order) = (spare);                                                                  \
            (spare) = swap;                                                                     \
        }                                                                                       \
    } while (0)

/* The stable ascending order of keys[0:n]: written to `order` (n) using `spare` (n) as scratch;
 * returns whichever of the two holds the result. */
static inline int64_t *stable_order(const int64_t *keys, int64_t n, int64_t *order, int64_t *spare) {
#define KEY_LE(a, b) (keys[a] <= keys[b])
    K_STABLE_ORDER(n, order, spare, KEY_LE);
#undef KEY_LE
    return order;
}

#endif
