"""One attribute model for every reader: a building's source attributes as a flat dict of
``str -> str | int | float | bool`` (``Building.attributes``, the manifest's ``attributes``).

Readers hand :func:`clean_attributes` their (key, value) pairs in source order; it applies the
rules of ``docs/input.md`` ("Attributes") and returns the dict plus notes for ``problems``. No
value ever stops a building:

- nested objects are flattened with dotted keys (``{"address": {"city": "Z"}}`` ->
  ``address.city``), up to :data:`MAX_DEPTH` levels, deeper ones kept as a JSON string;
  lists are kept as compact JSON strings (sorted keys);
- ``None``/JSON ``null``, NaN and infinities are left out (noted);
- integers beyond int64 become their decimal text; bools stay bools;
- bytes are decoded as UTF-8 with undecodable bytes replaced by U+FFFD; text that cannot be
  encoded as UTF-8 (lone surrogates from ``\\ud800`` escapes) likewise;
- text longer than :data:`MAX_TEXT` characters is cut by :func:`exporter.names.bounded_text`
  (the rule for every text taken from input: ``…`` and 8 hex digits of its SHA-1 follow; noted);
- keys are stripped text (an empty key is left out); a key seen again keeps its first value
  (noted): the source's order decides;
- at most :data:`MAX_ATTRIBUTES` attributes per building, the rest left out (noted).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from typing import Any

from .names import MAX_TEXT_CHARS, bounded_text

MAX_TEXT = MAX_TEXT_CHARS  # characters of one text value (docs/input.md: texts are bounded)
MAX_DEPTH = 8  # levels of nested objects flattened into dotted keys
MAX_ATTRIBUTES = 256  # per building
INT64 = (-(2**63), 2**63 - 1)

Value = str | int | float | bool


def clean_text(text: str | bytes | bytearray) -> str:
    """``text`` as valid UTF-8 text (bytes decoded, bad bytes and lone surrogates -> U+FFFD)."""
    if isinstance(text, (bytes, bytearray)):
        return bytes(text).decode("utf-8", errors="replace")
    return text.encode("utf-8", errors="surrogatepass").decode("utf-8", errors="replace")


def _text(text: str | bytes | bytearray, notes: list[str], key: str) -> str:
    out = clean_text(text)
    if len(out) > MAX_TEXT:
        notes.append(f"attribute {key} cut to {MAX_TEXT} of {len(out)} characters")
        out = bounded_text(out, MAX_TEXT)
    return out


def _json_text(value: Any) -> str:
    return json.dumps(value, ensure_ascii=False, sort_keys=True, separators=(",", ":"), default=str)


def _flat(key: str, value: Any, depth: int, notes: list[str]) -> Iterable[tuple[str, Value]]:
    """(key, value) pairs of one source attribute after the rules of the module doc."""
    if isinstance(value, bool):
        yield key, value
    elif isinstance(value, int):
        yield key, value if INT64[0] <= value <= INT64[1] else str(value)
    elif isinstance(value, float):
        if math.isfinite(value):
            yield key, value
        else:
            notes.append(f"attribute {key!r}: {value} left out")
    elif isinstance(value, (str, bytes, bytearray)):
        yield key, _text(value, notes, key)
    elif value is None:
        notes.append(f"attribute {key!r}: null left out")
    elif isinstance(value, dict) and depth < MAX_DEPTH:
        for inner, item in value.items():
            yield from _flat(f"{key}.{clean_text(str(inner)).strip()}", item, depth + 1, notes)
    else:  # lists, objects nested too deep, anything else: compact JSON text
        yield key, _text(_json_text(value), notes, key)


def clean_attributes(pairs: Iterable[tuple[Any, Any]]) -> tuple[dict[str, Value], list[str]]:
    """The attributes of ``pairs`` (source order) after the module doc's rules, and notes for
    the building's ``problems`` (one per kind of change, at most a few)."""
    out: dict[str, Value] = {}
    notes: list[str] = []
    dropped = 0
    for raw_key, raw_value in pairs:
        key = clean_text(raw_key if isinstance(raw_key, (str, bytes)) else str(raw_key)).strip()
        if not key:
            notes.append("attribute with an empty name left out")
            continue
        for name, value in _flat(key, raw_value, 0, notes):
            if name in out:
                notes.append(f"attribute {name!r} given again: the first value kept")
            elif len(out) >= MAX_ATTRIBUTES:
                dropped += 1
            else:
                out[name] = value
    if dropped:
        notes.append(f"{dropped} attribute(s) beyond the first {MAX_ATTRIBUTES} left out")
    return out, list(dict.fromkeys(notes))[:8]
