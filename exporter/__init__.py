"""vworld-lod: turn 3D building tiles into Unity-ready glTF LoD chains and a LODGroup manifest.

Pipeline (one module per stage, see docs/ARCHITECTURE.md):
read (``readers``) -> simplify (``simplify``) -> textures (``textures``) -> place (``placement``,
``tiles``) -> write (``gltf_writer``) -> manifest (``manifest``), on the mesh layer (``mesh``),
one building at a time by ``job``, driven by ``pipeline`` (or ``distributed``) and ``cli``.
"""

__version__ = "0.8.1"
