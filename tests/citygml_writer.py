"""The tests' own CityGML writer (and a CityJSON writer for the same buildings).

A building is a dict: ``id``, ``surfaces`` [(thematic type, [ring, ...]), ...] with rings lists of
(x, y, z) source-CRS points (exterior first, counter-clockwise seen from outside, no closing
point), optional ``name`` / ``height`` / ``function`` attributes and ``parts`` (buildings written
as BuildingParts). Polygons get ids ``<building>_p<i>`` and rings ``<building>_p<i>_r<j>``.
"""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import escape

NAMESPACES = {
    "1.0": ("http://www.opengis.net/citygml/1.0", "http://www.opengis.net/citygml/building/1.0"),
    "2.0": ("http://www.opengis.net/citygml/2.0", "http://www.opengis.net/citygml/building/2.0"),
}
APPEARANCE = {
    "1.0": "http://www.opengis.net/citygml/appearance/1.0",
    "2.0": "http://www.opengis.net/citygml/appearance/2.0",
}


def box(x0: float, y0: float, z0: float, w: float, d: float, h: float) -> list:
    """A w x d x h metre box as (type, [ring]) surfaces, rings counter-clockwise from outside."""
    x1, y1, z1 = x0 + w, y0 + d, z0 + h
    return [
        ("GroundSurface", [[(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)]]),
        ("RoofSurface", [[(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]]),
        ("WallSurface", [[(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)]]),
        ("WallSurface", [[(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)]]),
        ("WallSurface", [[(x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)]]),
        ("WallSurface", [[(x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)]]),
    ]


def with_window(surfaces: list) -> list:
    """``surfaces`` with a hole (clockwise from outside) in the first wall (the south wall)."""
    out = list(surfaces)
    kind, rings = out[2]
    (x0, y0, z0), (x1, _, _), _, (_, _, z1) = rings[0]
    a, b = x0 + (x1 - x0) / 3, x0 + 2 * (x1 - x0) / 3
    c, e = z0 + (z1 - z0) / 3, z0 + 2 * (z1 - z0) / 3
    out[2] = (kind, [rings[0], [(a, y0, c), (a, y0, e), (b, y0, e), (b, y0, c)]])
    return out


def pos_list(ring, close: bool = True, fmt: str = "{!r}") -> str:
    points = [*ring, ring[0]] if close else list(ring)
    return " ".join(fmt.format(float(v)) for p in points for v in p)


def polygon(pid: str, rings: list, close: bool = True) -> str:
    body = []
    for j, ring in enumerate(rings):
        tag = "exterior" if j == 0 else "interior"
        body.append(
            f'<gml:{tag}><gml:LinearRing gml:id="{pid}_r{j}"><gml:posList>'
            f"{pos_list(ring, close)}</gml:posList></gml:LinearRing></gml:{tag}>"
        )
    return f'<gml:Polygon gml:id="{pid}">{"".join(body)}</gml:Polygon>'


def _attributes(building: dict, bldg: str) -> str:
    out = f"<gml:name>{escape(building['name'])}</gml:name>" if "name" in building else ""
    if "function" in building:
        out += f"<{bldg}:function>{building['function']}</{bldg}:function>"
    if "height" in building:
        out += f'<{bldg}:measuredHeight uom="m">{building["height"]}</{bldg}:measuredHeight>'
    return out


def building_xml(
    building: dict, mode: str = "boundedBy", tag: str = "Building", lod: int = 2
) -> str:
    """One bldg:Building (or BuildingPart). ``mode``: ``boundedBy`` (thematic surfaces with
    lod{lod}MultiSurface), ``solid`` (lod{lod}Solid whose CompositeSurface references the
    thematic polygons by xlink:href) or ``multisurface`` (one lod{lod}MultiSurface, no semantics)."""
    bid = building["id"]
    polygons = [
        (kind, polygon(f"{bid}_p{i}", rings))
        for i, (kind, rings) in enumerate(building["surfaces"])
    ]
    body = _attributes(building, "bldg")
    if mode == "multisurface":
        members = "".join(f"<gml:surfaceMember>{p}</gml:surfaceMember>" for _, p in polygons)
        body += f"<bldg:lod{lod}MultiSurface><gml:MultiSurface>{members}</gml:MultiSurface></bldg:lod{lod}MultiSurface>"
    else:
        if mode == "solid":
            refs = "".join(
                f'<gml:surfaceMember xlink:href="#{bid}_p{i}"/>' for i in range(len(polygons))
            )
            body += (
                f"<bldg:lod{lod}Solid><gml:Solid><gml:exterior><gml:CompositeSurface>{refs}"
                f"</gml:CompositeSurface></gml:exterior></gml:Solid></bldg:lod{lod}Solid>"
            )
        for kind, p in polygons:
            body += (
                f"<bldg:boundedBy><bldg:{kind}><bldg:lod{lod}MultiSurface><gml:MultiSurface>"
                f"<gml:surfaceMember>{p}</gml:surfaceMember></gml:MultiSurface>"
                f"</bldg:lod{lod}MultiSurface></bldg:{kind}></bldg:boundedBy>"
            )
    for part in building.get("parts", []):
        body += f"<bldg:consistsOfBuildingPart>{building_xml(part, mode, 'BuildingPart', lod)}</bldg:consistsOfBuildingPart>"
    body += building.get("extra", "")
    return f'<bldg:{tag} gml:id="{bid}">{body}</bldg:{tag}>'


def citygml(
    buildings: list[dict],
    srs: str | None = "EPSG:25832",
    version: str = "2.0",
    mode: str = "boundedBy",
    appearance: str = "",
) -> str:
    """A CityModel document of ``buildings`` (srsName on the CityModel's envelope when given)."""
    core, bldg = NAMESPACES[version]
    envelope = (
        f'<gml:boundedBy><gml:Envelope srsName="{srs}" srsDimension="3">'
        "<gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner>"
        "</gml:Envelope></gml:boundedBy>"
        if srs
        else ""
    )
    members = "".join(
        f"<cityObjectMember>{building_xml(b, mode)}</cityObjectMember>" for b in buildings
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<CityModel xmlns="{core}" xmlns:bldg="{bldg}" xmlns:app="{APPEARANCE[version]}" '
        'xmlns:gml="http://www.opengis.net/gml" xmlns:xlink="http://www.w3.org/1999/xlink">\n'
        f"{envelope}\n{members}\n{appearance}</CityModel>\n"
    )


def texture_member(image: str, polygon_id: str, rings_uv: list[list]) -> str:
    """An app:ParameterizedTexture on polygon ``polygon_id``: one uv list per ring (closing
    coordinate added)."""
    lists = "".join(
        f'<app:textureCoordinates ring="#{polygon_id}_r{j}">{pos_list(uv, True, "{:g}")}</app:textureCoordinates>'
        for j, uv in enumerate(rings_uv)
    )
    return (
        f"<app:surfaceDataMember><app:ParameterizedTexture><app:imageURI>{image}</app:imageURI>"
        f'<app:target uri="#{polygon_id}"><app:TexCoordList>{lists}</app:TexCoordList></app:target>'
        "</app:ParameterizedTexture></app:surfaceDataMember>"
    )


def appearance_member(members: str, theme: str = "rgbTexture") -> str:
    return (
        f"<app:appearanceMember><app:Appearance><app:theme>{theme}</app:theme>{members}"
        "</app:Appearance></app:appearanceMember>"
    )


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def cityjson(buildings: list[dict], crs: str = "EPSG:25832") -> dict:
    """The same buildings as CityJSON 2.0 (one MultiSurface per building, semantics kept)."""
    vertices: list = []
    index: dict = {}
    objects: dict = {}

    def add(building: dict, parent: str | None) -> None:
        boundaries, values, types = [], [], []
        for kind, rings in building["surfaces"]:
            surface = []
            for ring in rings:
                ids = []
                for point in ring:
                    if point not in index:
                        index[point] = len(vertices)
                        vertices.append(list(point))
                    ids.append(index[point])
                surface.append(ids)
            boundaries.append(surface)
            if kind not in types:
                types.append(kind)
            values.append(types.index(kind))
        objects[building["id"]] = {
            "type": "BuildingPart" if parent else "Building",
            "geometry": [
                {
                    "type": "MultiSurface",
                    "lod": "2",
                    "boundaries": boundaries,
                    "semantics": {"surfaces": [{"type": t} for t in types], "values": values},
                }
            ],
            **({"parents": [parent]} if parent else {}),
            **({"children": [p["id"] for p in building["parts"]]} if building.get("parts") else {}),
        }
        for part in building.get("parts", []):
            add(part, building["id"])

    for building in buildings:
        add(building, None)
    return {
        "type": "CityJSON",
        "version": "2.0",
        "metadata": {
            "referenceSystem": f"https://www.opengis.net/def/crs/EPSG/0/{crs.split(':')[-1]}"
        },
        "CityObjects": objects,
        "vertices": vertices,
    }


def write_cityjson(path: Path, buildings: list[dict], crs: str = "EPSG:25832") -> Path:
    return write(path, json.dumps(cityjson(buildings, crs)))
