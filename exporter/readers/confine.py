"""Paths named inside input data stay inside the input's own folder (one rule for every reader).

A file the input data names (a CityJSON texture ``image``, a CityGML ``app:imageURI``, an index
file's ``file`` column, an OBJ's ``mtllib``, an MTL's ``map_Kd``, a glTF buffer or image ``uri``, a
VWorld ``.dat``/``.xdo`` file name) is read only when it resolves, symlinks followed, inside the
input's folder: the folder given, or the folder of the file given. An absolute path, a ``../``
climbing out or a symlink leading out is refused, so that exporting someone's data never copies
another file of the machine into the output (issue 36). Each reader turns the refusal into a
problem of that building (an image: the part is exported untextured) or a skipped index row.
"""

from __future__ import annotations

import os
from pathlib import Path


class OutsideInput(ValueError):
    """A path named in the input leads outside the input's folder; ``str()`` says which."""


def confined(name: str | os.PathLike, relative_to: Path, root: Path | None = None) -> Path:
    """The file ``name`` (as written in the input, relative to folder ``relative_to``) as
    ``relative_to / name`` when it resolves inside ``root`` (default ``relative_to``) after
    symlinks are followed; raises :class:`OutsideInput` naming ``name`` otherwise.

    The file need not exist (a missing file is the caller's other problem)."""
    text = os.fspath(name)
    path = Path(relative_to) / text
    if root is None and _plain_name(text) and not os.path.islink(path):
        return path  # a plain file name in the folder itself: one lstat, not two realpaths
    root = relative_to if root is None else root
    try:
        inside = Path(os.path.realpath(path)).is_relative_to(os.path.realpath(root))
    except (OSError, ValueError):  # e.g. a NUL byte or a symlink loop
        inside = False
    if not inside:
        raise OutsideInput(f"{text!r} leads outside the input folder {root}")
    return path


def _plain_name(text: str) -> bool:
    """A name that can only mean a file of the folder itself (no separator, drive or dot-dot)."""
    separators = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    return (
        bool(text)
        and text not in (".", "..")
        and not any(sep in text for sep in separators)
        and ":" not in text
        and "\0" not in text
    )
