"""Low-level binary layouts of source formats: bytes in, dataclasses out, and back.

Modules here do no file I/O and no frame conversion; readers (``exporter/readers``) and the sample
writer build on them. ``vworld_binary``: VWorld ``.dat`` tile indexes and ``.xdo`` building models.
"""
