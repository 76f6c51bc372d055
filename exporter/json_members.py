"""JSON text read member by member: a file's top-level members with the exact text of each value
(a record's line copied into a manifest without encoding it again), or only its leading members
(a proxy record's summary fields, before its per-building lists).

Pure functions on ``str``; the standard library's decoder parses each value.
"""

from __future__ import annotations

import json
import re

_DECODER = json.JSONDecoder()
_SPACE = re.compile(r"[ \t\n\r]*")


def _skip(text: str, at: int) -> int:
    """The index of the first non-blank character of ``text`` from ``at``."""
    match = _SPACE.match(text, at)
    return match.end() if match else at


def top_level_values(
    text: str, until: frozenset[str] = frozenset()
) -> dict[str, tuple[object, str]]:
    """The members of the JSON object ``text`` as (value, the value's exact text), by key (the
    text lets a record be copied into the manifest without encoding it again). Raises
    ValueError when ``text`` is not one JSON object. With ``until``, the members up to the first
    point where every key of it has been read (the rest neither parsed nor checked: a file
    whose leading members are all a reader needs, as a proxy record's before its buildings)."""
    out: dict[str, tuple[object, str]] = {}
    at = _skip(text, 0)
    if text[at : at + 1] != "{":
        raise ValueError("not a JSON object")
    at = _skip(text, at + 1)
    if text[at : at + 1] == "}":
        at += 1
    else:
        while True:
            key, at = _DECODER.raw_decode(text, at)
            at = _skip(text, at)
            if not isinstance(key, str) or text[at : at + 1] != ":":
                raise ValueError(f"bad member at {at}")
            start = _skip(text, at + 1)
            value, end = _DECODER.raw_decode(text, start)
            out[key] = (value, text[start:end])
            if until and until.issubset(out):
                return out
            at = _skip(text, end)
            if text[at : at + 1] == ",":
                at = _skip(text, at + 1)
            elif text[at : at + 1] == "}":
                at += 1
                break
            else:
                raise ValueError(f"expected , or }} at {at}")
    if text[at:].strip():
        raise ValueError("extra data after the object")
    return out
