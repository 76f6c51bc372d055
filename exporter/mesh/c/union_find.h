/* Union-find (Tarjan, "Efficiency of a good but not linear set union algorithm", 1975) with path
 * halving; callers link the larger root under the smaller, so a component's root is its lowest
 * node. */
#ifndef EXPORTER_MESH_UNION_FIND_H
#define EXPORTER_MESH_UNION_FIND_H

#include <stdint.h>

/* The root of node a in the forest `parent`, halving its path. */
static inline int64_t uf_root(int64_t *parent, int64_t a) {
    while (parent[a] != a) {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    return a;
}

/* Joins the components of a and b under the lower root. */
static inline void uf_join(int64_t *parent, int64_t a, int64_t b) {
    a = uf_root(parent, a);
    b = uf_root(parent, b);
    if (a < b) parent[b] = a;
    else if (b < a) parent[a] = b;
}

#endif
