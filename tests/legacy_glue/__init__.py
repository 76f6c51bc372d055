"""Frozen copy of the mesh stage's glue as it was before the speed-glue work (commit 895b66a):
``exporter/simplify/{__init__,meshopt,weld,protect,guard}.py`` and ``exporter/geometry.py``, with
the imports of the modules that did not change (config, model, planar, quadric, hausdorff,
quality) pointed at the package. tests/test_perf_glue.py compares :func:`build_mesh_chain`'s
outputs with this copy's bit for bit; nothing else imports it.
"""
