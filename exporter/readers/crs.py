"""The readers' one CRS rule: which coordinate reference system a file's coordinates are read in.

``--override-crs`` (``readers.override_crs``) replaces whatever a file declares; otherwise a
declared CRS always wins; ``--crs`` (``readers.crs``) serves only files that declare none; a file
with none of the three is refused (a CRS is never guessed). Each reader turns the choice into its
own error messages (naming its format's CRS field) and bookkeeping.
"""

from __future__ import annotations


def choose_crs(
    override: str | None, declared: str | None, option: str | None
) -> tuple[str, str] | None:
    """``(CRS text as given, where it came from: "override", "declared" or "option")``, or None
    when the file declares none and neither option gives one (empty texts count as none)."""
    for text, source in ((override, "override"), (declared, "declared"), (option, "option")):
        if text:
            return str(text), source
    return None
