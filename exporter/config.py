"""The exporter's configuration: defaults from the paper, loaded from and written as YAML.

A user's YAML may give any subset of the keys; what it omits keeps the default. ``lods`` is
replaced as a whole when given. Everything is checked before any work starts: an unknown key, a
wrong type, a ratio outside (0, 1], transitions that do not strictly decrease or more than 8 levels
raise :class:`~exporter.errors.ConfigError` naming the file, the key and what is allowed.

Percentages are accepted as ``50%`` or ``0.5``.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib.util
import math
import reprlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError

MAX_LODS = 8  # Unity's LODGroup holds at most 8 levels.


# A value is quoted in an error bounded in depth, items and characters: YAML aliases can make a
# 400-byte file a structure whose full repr has 10^9 items ("billion laughs").
_SHOWN = reprlib.Repr()
_SHOWN.maxlevel, _SHOWN.maxlist, _SHOWN.maxdict, _SHOWN.maxstring, _SHOWN.maxother = 2, 4, 4, 80, 80


def shown(value: Any) -> str:
    """``repr(value)``, bounded (``...`` for what is left out)."""
    return _SHOWN.repr(value)


# --------------------------------------------------------------------------- value parsers
# Each parser takes the raw YAML value and returns the checked value or raises ValueError whose
# text says what is allowed.


def parse_ratio(value: Any) -> float:
    """A number in (0, 1], written ``0.5`` or ``50%``."""
    allowed = "a ratio in (0, 1], written like 0.5 or 50%"
    if isinstance(value, bool):
        raise ValueError(f"got {shown(value)}; allowed: {allowed}")
    if isinstance(value, str):
        text = value.strip()
        try:
            number = float(text[:-1]) / 100.0 if text.endswith("%") else float(text)
        except ValueError:
            raise ValueError(f"got {shown(value)}; allowed: {allowed}") from None
    elif isinstance(value, (int, float)):
        number = float(value)
    else:
        raise ValueError(f"got {shown(value)}; allowed: {allowed}")
    if not (0.0 < number <= 1.0):  # NaN fails here too
        raise ValueError(f"got {shown(value)}; allowed: {allowed}")
    return number


def parse_ratio_or_zero(value: Any) -> float:
    """A number in [0, 1] (``0%`` allowed), written ``0.3`` or ``30%``."""
    if value in (0, "0", "0%", 0.0):
        return 0.0
    try:
        return parse_ratio(value)
    except ValueError:
        raise ValueError(
            f"got {shown(value)}; allowed: a ratio in [0, 1], written like 0.3 or 30%"
        ) from None


def parse_bool(value: Any) -> bool:
    if isinstance(value, bool):
        return value
    raise ValueError(f"got {shown(value)}; allowed: true or false")


def _number(minimum: float, inclusive: bool = True, maximum: float = 1e9) -> Callable[[Any], float]:
    """A finite number in [minimum, maximum] (or (minimum, maximum]): ``.inf`` and ``.nan`` are
    refused before any work (an infinite radius only fails when the manifest is written)."""
    low = ">=" if inclusive else ">"
    text = f"a finite number {low} {minimum:g} and <= {maximum:g}"

    def parse(value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"got {shown(value)}; allowed: {text}")
        ok = math.isfinite(value) and (value >= minimum if inclusive else value > minimum)
        ok = ok and value <= maximum
        if not ok:
            raise ValueError(f"got {shown(value)}; allowed: {text}")
        return float(value)

    return parse


def _integer(minimum: int, maximum: int | None = None) -> Callable[[Any], int]:
    text = f"an integer >= {minimum}" + (f" and <= {maximum}" if maximum is not None else "")

    def parse(value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"got {shown(value)}; allowed: {text}")
        if value < minimum or (maximum is not None and value > maximum):
            raise ValueError(f"got {shown(value)}; allowed: {text}")
        return int(value)

    return parse


def _choice(*choices: str) -> Callable[[Any], str]:
    def parse(value: Any) -> str:
        if value not in choices:
            raise ValueError(f"got {shown(value)}; allowed: one of {', '.join(choices)}")
        return value

    return parse


def parse_crs_option(value: Any) -> str | None:
    """A coordinate reference system PROJ knows (``EPSG:7415``, an OGC URL or URN) or null;
    checked here so that a typo is named as the option's, not blamed on an input file."""
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"got {shown(value)}; allowed: a CRS such as EPSG:7415, or null")
    from .geodesy import check_crs  # pyproj: imported only when a CRS is given

    check_crs(value)
    return value


# --------------------------------------------------------------------------- sections
# ``meta(parser, doc)`` attaches the parser and the comment written by ``init-config``.


def meta(parser: Callable[[Any], Any], doc: str) -> dict:
    return {"parse": parser, "doc": doc}


@dataclass
class LodSpec:
    """One level of detail: LOD0 first."""

    transition: float = field(
        metadata=meta(
            parse_ratio,
            "screen-relative height (0-1 or %) below which this level hands over to the next; below the last level the building is culled",
        )
    )
    mesh: float = field(
        default=1.0,
        metadata=meta(
            parse_ratio,
            "largest share of LOD0's triangles the level may keep (a cap: the level goes further while its screen error budget allows; the budget wins when the cap cannot be reached within it)",
        ),
    )
    texture: float = field(
        default=1.0,
        metadata=meta(
            parse_ratio,
            "texture scale per side relative to the source atlas (0.5 = a quarter of the pixels)",
        ),
    )
    terrain_level: int | None = field(
        default=None,
        metadata=meta(
            lambda v: None if v is None else _integer(0, 30)(v),
            "VWorld terrain tile level this LoD pairs with (default: 15 for LOD0, one less per level)",
        ),
    )


@dataclass
class SimplifyOptions:
    """The paper's Table II options plus the geometric filter."""

    protect_largest: float = field(
        default=0.30,
        metadata=meta(
            parse_ratio_or_zero,
            "share of faces, largest area first, never simplified (the paper's geometric filter)",
        ),
    )
    preserve_border_edges: bool = field(
        default=True,
        metadata=meta(
            parse_bool,
            "keep edges used by one triangle only (the open bottom and outline of a floorless building) in place",
        ),
    )
    preserve_uv_seam_edges: bool = field(
        default=True,
        metadata=meta(
            parse_bool, "keep edges where one position has two different UVs (texture seams)"
        ),
    )
    preserve_uv_foldover_edges: bool = field(
        default=True,
        metadata=meta(
            parse_bool,
            "refuse collapses that fold the texture over itself (flip a triangle in UV space)",
        ),
    )
    preserve_surface_curvature: bool = field(
        default=False,
        metadata=meta(
            parse_bool,
            "weigh collapses by surface curvature so curved parts (domes) keep their shape",
        ),
    )
    vertex_link_distance: float = field(
        default=0.0,
        metadata=meta(
            _number(0.0, maximum=1000.0),
            "metres: weld vertices closer than this before simplifying (0 = only float noise, closer than 1 micrometre)",
        ),
    )
    max_iterations: int = field(
        default=100, metadata=meta(_integer(1, 100000), "maximum simplification passes per level")
    )
    max_screen_error_px: float = field(
        default=2.0,
        metadata=meta(
            _number(0.0, maximum=1e6),
            "largest allowed deviation of a level from LOD0 in pixels, when the level is shown at the largest size the LODGroup shows it (lods[k-1].transition x reference_screen_height_px for level k); converted per building to metres with LODGroup.size = the largest side of the bounds (certified by the error guard; 0 = no limit: every level goes to its mesh cap)",
        ),
    )
    reference_screen_height_px: int = field(
        default=1080,
        metadata=meta(
            _integer(1, 1_000_000),
            "screen height in pixels that max_screen_error_px refers to (1080 = Full HD)",
        ),
    )
    engine: str = field(
        default="meshoptimizer",
        metadata=meta(
            _choice("meshoptimizer", "pymeshlab"),
            "edge-collapse engine: meshoptimizer (meshopt_simplifyWithAttributes, searched on its error target) or pymeshlab (quadric edge collapse, searched on the triangle count)",
        ),
    )
    protect_walls: bool = field(
        default=False,
        metadata=meta(
            parse_bool,
            "also keep near-vertical faces standing on the open bottom border (the walls on the footprint outline) out of the quadric collapse",
        ),
    )
    min_silhouette_iou: float = field(
        default=0.97,
        metadata=meta(
            parse_ratio_or_zero,
            "a level whose silhouette (top, front and side, IoU against LOD0 on a 128 x 128 raster of LOD0's box) keeps less than this is refused like one above its error budget, so thin parts (towers, spires) keep their outline (0 = off)",
        ),
    )
    planar_retriangulation: bool = field(
        default=True,
        metadata=meta(
            parse_bool,
            "first re-triangulate every flat polygon from its outline (lossless: same surface, same UV mapping, same outlines)",
        ),
    )


@dataclass
class GlobeOptions:
    """Placement on the paper's spherical, left-handed, y-up globe (equations 1-2)."""

    unity_radius: float = field(
        default=6378137.0,
        metadata=meta(
            _number(0.0, inclusive=False, maximum=1e12),
            "UR: the Earth's radius in Unity units (6378137 = 1 unit per metre)",
        ),
    )
    earth_radius: float = field(
        default=6378137.0,
        metadata=meta(
            _number(0.0, inclusive=False), "R: the real Earth radius in metres (VWorld's sphere)"
        ),
    )
    placement: str = field(
        default="tile_relative",
        metadata=meta(
            _choice("tile_relative", "globe"),
            "which placement the Unity package applies: tile_relative (tile root + small local numbers, no float jitter) or globe (the paper's absolute one)",
        ),
    )


@dataclass
class UnityOptions:
    """How the Unity package sets up each LODGroup."""

    fade_mode: str = field(
        default="none",
        metadata=meta(
            _choice("none", "cross_fade", "speed_tree"),
            "LODGroup.fadeMode; cross_fade needs shaders with LOD cross-fade, which glTFast's lack (both levels draw during a fade; the Unity package warns)",
        ),
    )
    animate_cross_fading: bool = field(
        default=False, metadata=meta(parse_bool, "LODGroup.animateCrossFading (with cross_fade)")
    )
    fade_transition_width: float = field(
        default=0.0,
        metadata=meta(
            parse_ratio_or_zero, "LOD.fadeTransitionWidth for every level (with cross_fade)"
        ),
    )


KTX2_INSTALL = "pip install 'vworld-lod[ktx2]'"
KTX2_MODULE = "alktx2"  # the encoder exporter/ktx2.py calls


def ktx2_encoder_installed() -> bool:
    """Whether the optional KTX2 encoder (:data:`KTX2_MODULE`) can be imported (not imported here)."""
    return importlib.util.find_spec(KTX2_MODULE) is not None


@dataclass
class TextureOptions:
    """Texture LoDs: each level's atlas scaled per side by lods[].texture."""

    jpeg_quality: int = field(
        default=90,
        metadata=meta(
            _integer(1, 100),
            "JPEG quality of the reduced atlases (LOD0 keeps the source bytes, or its tables when cropped)",
        ),
    )
    min_size: int = field(
        default=16, metadata=meta(_integer(1, 16384), "pixels: no atlas side is reduced below this")
    )
    fast_jpeg_downscale: str = field(
        default="auto",
        metadata=meta(
            _choice("auto", "always", "never"),
            "decode JPEG at reduced size (DCT scaling), each later level from the previous one; auto = DCT scaling, and later levels by box filter (as mipmaps), only where a sampled check predicts >= 35 dB PSNR against Lanczos (else full decode / Lanczos); always = both everywhere (fastest; aliases pixel-sharp detail); never = Lanczos from the full image for every level",
        ),
    )
    crop_to_used: bool = field(
        default=True,
        metadata=meta(
            parse_bool,
            "cut a JPEG/PNG atlas that a building uses only partly (a shared atlas) to the region its uvs use, before the texture LoDs (LOD0: JPEG re-encoded with the source's own tables on MCU boundaries, PNG losslessly); fully used atlases (VWorld's) keep their bytes",
        ),
    )
    opaque_png_to_jpeg: bool = field(
        default=False,
        metadata=meta(parse_bool, "write reduced levels of fully opaque PNG atlases as JPEG"),
    )
    max_pixels: int = field(
        default=16384 * 16384,
        metadata=meta(
            _integer(1, 1 << 40),
            "refuse a source atlas with more pixels than this, from its header before decoding (bounded memory; Pillow's own smaller limit is not applied)",
        ),
    )
    ktx2: bool = field(
        default=False,
        metadata=meta(
            parse_bool,
            f"also embed each atlas as KTX2 (Basis Universal ETC1S, KHR_texture_basisu; the JPEG/PNG stays as the fallback); needs the optional encoder: {KTX2_INSTALL}",
        ),
    )


@dataclass
class ReaderOptions:
    """How the readers turn source files into buildings."""

    drop_ground_surfaces: bool = field(
        default=True,
        metadata=meta(
            parse_bool, "drop CityJSON GroundSurface polygons (VWorld-style floorless models)"
        ),
    )
    crs: str | None = field(
        default=None,
        metadata=meta(
            parse_crs_option,
            "CRS of input files that do not declare one, e.g. EPSG:7415 (never guessed; files declaring one keep theirs, and a run where none lacks one is refused)",
        ),
    )
    override_crs: str | None = field(
        default=None,
        metadata=meta(
            parse_crs_option,
            "CRS that replaces what every input file declares (for files declaring a wrong one; each building notes it in its problems)",
        ),
    )
    max_vertex_distance_m: float = field(
        default=2000.0,
        metadata=meta(
            _number(0.0, inclusive=False),
            "metres: a building with a vertex farther than this from the median of its vertices is refused and listed in skipped (a stray vertex would move and stretch it); a vertex that is not a finite number refuses its building only",
        ),
    )
    citygml_lod: int = field(
        default=2,
        metadata=meta(
            _integer(0, 4),
            "CityGML: read the highest LoD at or below this one (0-4) a building has, else its lowest",
        ),
    )


@dataclass
class TilesetOptions:
    """OUT/tileset.json (3D Tiles 1.1) and its HLOD proxies (exporter/tileset/)."""

    enabled: bool = field(
        default=True,
        metadata=meta(parse_bool, "write OUT/tileset.json after the manifests and tiles.json"),
    )
    proxies: bool = field(
        default=True,
        metadata=meta(parse_bool, "merged, simplified proxies for the tiles above the buildings"),
    )
    proxy_max_triangles: int = field(
        default=300_000,
        metadata=meta(
            _integer(1),
            "a proxy is clustered on coarser cells until it holds at most half this (a parent: at most its largest child, at least 1/32 of this, while its faces fall as fast as cell^-2; docs/tileset.md); a tile gets no proxy (nor do its ancestors) when even tile-sized cells leave more",
        ),
    )
    proxy_error_ratio: float = field(
        default=0.01,
        metadata=meta(
            _number(0.0, maximum=1.0),
            "a tile's proxy is simplified (per-building vertex clustering, its error bounded by construction) towards this x the tile's north-south size in metres (0 = merge only)",
        ),
    )
    proxy_atlas_size: int = field(
        default=2048,
        metadata=meta(
            _integer(16, 16384),
            "largest pixels per side of a proxy's one texture atlas: each proxy's is the smallest power of two (from 64) whose texels on its surface are at most 1/4 of the error it is shown at (its geometric error, or its children's when larger), or whose cells hold their images whole, up to this",
        ),
    )


def default_lods() -> list[LodSpec]:
    # The paper's Fig. 12 transitions and texture quarters; mesh ratios at least as strong as its
    # Table III result (67.46 %, 48.07 % of LOD0).
    return [
        LodSpec(transition=0.50, mesh=1.0, texture=1.0),
        LodSpec(transition=0.17, mesh=0.65, texture=0.5),
        LodSpec(transition=0.02, mesh=0.45, texture=0.25),
    ]


@dataclass
class Config:
    lods: list[LodSpec] = field(default_factory=default_lods)
    simplify: SimplifyOptions = field(default_factory=SimplifyOptions)
    globe: GlobeOptions = field(default_factory=GlobeOptions)
    unity: UnityOptions = field(default_factory=UnityOptions)
    textures: TextureOptions = field(default_factory=TextureOptions)
    readers: ReaderOptions = field(default_factory=ReaderOptions)
    tileset: TilesetOptions = field(default_factory=TilesetOptions)

    def terrain_levels(self) -> list[int]:
        """Terrain tile level hint per LoD (the paper pairs building LoDs with terrain 15/14/13)."""
        return [
            spec.terrain_level if spec.terrain_level is not None else max(0, 15 - i)
            for i, spec in enumerate(self.lods)
        ]

    def to_dict(self) -> dict:
        """The effective configuration as plain data (written into the manifest). Opt-in keys
        that are off are left out (``textures.ktx2``), so exports without them are byte for byte
        what earlier versions wrote, and keep their reuse hashes."""
        data = dataclasses.asdict(self)
        if not data["textures"]["ktx2"]:
            del data["textures"]["ktx2"]
        for i, level in enumerate(data["lods"]):
            level["terrain_level"] = self.terrain_levels()[i]
        return data


SECTIONS = {
    "simplify": SimplifyOptions,
    "globe": GlobeOptions,
    "unity": UnityOptions,
    "textures": TextureOptions,
    "readers": ReaderOptions,
    "tileset": TilesetOptions,
}


# --------------------------------------------------------------------------- loading


def _parse_fields(cls, raw: Any, where: str, path: str, base=None):
    """Build dataclass ``cls`` from mapping ``raw``, starting from ``base`` (or the defaults)."""
    if not isinstance(raw, dict):
        raise ConfigError(
            path,
            where,
            f"got {type(raw).__name__}; allowed: a mapping of keys {', '.join(f.name for f in dataclasses.fields(cls))}",
        )
    known = {f.name: f for f in dataclasses.fields(cls)}
    values = {}
    for key, value in raw.items():
        if key not in known:
            raise ConfigError(path, f"{where}.{key}", unknown_key(key, list(known)))
        try:
            values[key] = known[key].metadata["parse"](value)
        except ValueError as error:
            raise ConfigError(path, f"{where}.{key}", str(error)) from None
    if base is not None:
        return dataclasses.replace(base, **values)
    missing = [
        name
        for name, f in known.items()
        if name not in values
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ConfigError(path, where, f"missing key(s) {', '.join(missing)}")
    return cls(**values)


def _parse_lods(raw: Any, path: str) -> list[LodSpec]:
    if not isinstance(raw, list) or not raw:
        raise ConfigError(
            path, "lods", f"got {shown(raw)}; allowed: a list of 1 to {MAX_LODS} levels, LOD0 first"
        )
    if len(raw) > MAX_LODS:
        raise ConfigError(
            path, "lods", f"{len(raw)} levels; allowed: 1 to {MAX_LODS} (Unity's LODGroup limit)"
        )
    lods = [_parse_fields(LodSpec, item, f"lods[{i}]", path) for i, item in enumerate(raw)]
    for i in range(1, len(lods)):
        if not lods[i].transition < lods[i - 1].transition:
            raise ConfigError(
                path,
                f"lods[{i}].transition",
                f"{lods[i].transition:g} is not below lods[{i - 1}].transition {lods[i - 1].transition:g}; allowed: strictly decreasing transitions, LOD0 first",
            )
        if lods[i].mesh > lods[i - 1].mesh:
            raise ConfigError(
                path,
                f"lods[{i}].mesh",
                f"{lods[i].mesh:g} is above lods[{i - 1}].mesh {lods[i - 1].mesh:g}; allowed: mesh ratios that never grow from one level to the next",
            )
        if lods[i].texture > lods[i - 1].texture:
            raise ConfigError(
                path,
                f"lods[{i}].texture",
                f"{lods[i].texture:g} is above lods[{i - 1}].texture {lods[i - 1].texture:g}; allowed: texture scales that never grow from one level to the next",
            )
    return lods


def config_from_dict(raw: Any, path: str = "<config>") -> Config:
    """Check and build a :class:`Config` from parsed YAML; ``path`` names the source in errors."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise ConfigError(
            path,
            "<top level>",
            f"got {type(raw).__name__}; allowed: a mapping with keys lods, {', '.join(SECTIONS)}",
        )
    config = Config()
    for key, value in raw.items():
        if key == "lods":
            config.lods = _parse_lods(value, path)
        elif key in SECTIONS:
            setattr(
                config,
                key,
                _parse_fields(
                    SECTIONS[key],
                    value if value is not None else {},
                    key,
                    path,
                    base=getattr(config, key),
                ),
            )
        else:
            raise ConfigError(path, str(key), unknown_key(key, ["lods", *SECTIONS]))
    check_optional_features(config, path)
    return config


def check_optional_features(config: Config, path: str = "<config>") -> None:
    """Refuse, before any work, an opt-in feature whose optional dependency is not installed."""
    if config.textures.ktx2 and not ktx2_encoder_installed():
        raise ConfigError(
            path,
            "textures.ktx2",
            f"true needs the KTX2 encoder ({KTX2_MODULE}: wheels for CPython 3.11-3.13 on Linux x86-64 and Windows x64), which is not installed: {KTX2_INSTALL}",
        )


def unknown_key(key: Any, allowed: list[str]) -> str:
    """The problem text for an unknown key: the likely one first (``simplfy`` -> ``simplify``),
    then every allowed key."""
    close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}? " if close else ""
    return f"unknown key; {hint}allowed keys: {', '.join(allowed)}"


def load_config(path: str | Path | None) -> Config:
    """Load and check a YAML config file; ``None`` gives the defaults."""
    if path is None:
        return Config()
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ConfigError(
            str(path), "<file>", f"cannot be read ({error.strerror or error})"
        ) from None
    except UnicodeDecodeError:
        raise ConfigError(str(path), "<file>", "not UTF-8 text (expected YAML)") from None

    try:
        duplicate = duplicate_key(yaml.compose(text, Loader=yaml.SafeLoader))
        raw = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise ConfigError(
            str(path), "<yaml>", f"not valid YAML ({str(error).splitlines()[0]})"
        ) from None
    except RecursionError:  # PyYAML composes nested collections recursively
        raise ConfigError(
            str(path), "<yaml>", "nested too deeply (a config is at most a few levels deep)"
        ) from None
    if duplicate is not None:
        key, lines = duplicate
        raise ConfigError(
            str(path),
            key,
            f"given more than once (lines {', '.join(map(str, lines))}); allowed: each key once",
        )
    return config_from_dict(raw, str(path))


def duplicate_key(
    node: yaml.Node | None, where: str = "", seen: set[int] | None = None
) -> tuple[str, list[int]] | None:
    """The first key given twice in one mapping of a composed YAML document, as (dotted key,
    1-based line numbers), or None. PyYAML itself keeps the last value silently. An aliased
    node is checked once (``seen``: node ids): a 400-byte "billion laughs" alias bomb stays
    hundreds of nodes instead of 10^9 visits."""
    seen = set() if seen is None else seen
    if id(node) in seen:
        return None
    seen.add(id(node))
    if isinstance(node, yaml.MappingNode):
        lines: dict[str, list[int]] = {}
        for key, _ in node.value:
            lines.setdefault(str(key.value), []).append(key.start_mark.line + 1)
        for name, found in lines.items():
            if len(found) > 1:
                return (f"{where}.{name}" if where else name), found
        children = [(f"{where}.{k.value}" if where else str(k.value), v) for k, v in node.value]
    elif isinstance(node, yaml.SequenceNode):
        children = [(f"{where}[{i}]", v) for i, v in enumerate(node.value)]
    else:
        return None
    for child_where, child in children:
        found_child = duplicate_key(child, child_where, seen)
        if found_child is not None:
            return found_child
    return None


# --------------------------------------------------------------------------- writing


def _yaml_value(value: Any) -> str:
    return (
        yaml.safe_dump(value, default_flow_style=True, width=1000)
        .strip()
        .removesuffix("...")
        .strip()
    )


def _percent(value: float) -> str:
    return f"{value * 100:g}%"


def default_config_yaml(config: Config | None = None) -> str:
    """The config as commented YAML, for ``vworld-lod init-config``; loads back to an equal Config."""
    config = config or Config()
    lines = [
        "# vworld-lod configuration. Every key is optional; omitted keys keep these defaults.",
        "# Percentages may be written 50% or 0.5.",
        "",
        f"# Levels of detail, LOD0 first (1 to {MAX_LODS}). transition: screen-relative height where the",
        "# level hands over to the next (strictly decreasing); below the last one the building is culled.",
        "# mesh: largest share of LOD0's triangles (a cap, the error budget may stop earlier); texture: atlas scale per side (0.5 = a quarter of the pixels).",
        "lods:",
    ]
    for spec in config.lods:
        entry = f"  - {{transition: {_percent(spec.transition)}, mesh: {spec.mesh:g}, texture: {spec.texture:g}"
        if spec.terrain_level is not None:
            entry += f", terrain_level: {spec.terrain_level}"
        lines.append(entry + "}")
    for name, cls in SECTIONS.items():
        section = getattr(config, name)
        lines += ["", f"# {(cls.__doc__ or name).strip().splitlines()[0]}", f"{name}:"]

        for f in dataclasses.fields(cls):
            value = getattr(section, f.name)
            shown = (
                _percent(value)
                if f.metadata["parse"] in (parse_ratio, parse_ratio_or_zero)
                else _yaml_value(value)
            )
            lines.append(f"  {f.name}: {shown}  # {f.metadata['doc']}")
    return "\n".join(lines) + "\n"
