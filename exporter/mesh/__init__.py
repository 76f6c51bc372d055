"""The mesh layer: geometry on indexed triangle meshes that every stage builds on.

Topology (edge use, borders, planar regions, welding, boundary loops, slits), distance
(point-triangle distance, the surface index, the certified Hausdorff bound and its region
certificates) and rasterisation (silhouettes). Arrays in, arrays out: ``positions`` (n, 3)
float64 metres in any one frame, ``faces`` (m, 3) int64. Nothing here imports a stage, the
model or the configuration (see docs/ARCHITECTURE.md, "Layers"). The hot loops are C
(``c/<algorithm>.c``, built at install into ``_<algorithm>``; the ``*_kernels`` modules check
their inputs and call them).
"""
