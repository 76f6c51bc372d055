"""The project's own error types. Every message names the file and the problem."""

from __future__ import annotations

import re

# ``<_io.BytesIO object at 0x7f...>``: an address differs from run to run (and says nothing to a
# user); problem texts go into manifests, which must be the same for the same input.
_ADDRESS = re.compile(r"<([\w.]+) object at 0x[0-9a-fA-F]+>")


def stable_text(text: str) -> str:
    """``text`` without object addresses (``<_io.BytesIO object at 0x…>`` -> ``<_io.BytesIO>``)."""
    return _ADDRESS.sub(r"<\1>", text)


def error_text(error: BaseException) -> str:
    """``"Type: message"`` of an unexpected error, run-independent (:func:`stable_text`)."""
    return stable_text(f"{type(error).__name__}: {error}")


class VWorldLodError(Exception):
    """Base class: anything the CLI reports as a one-line reason and a non-zero exit."""


class ConfigError(VWorldLodError):
    """The YAML config is unusable: names the file, the key and what is allowed."""

    def __init__(self, path: str, key: str, problem: str) -> None:
        self.path, self.key, self.problem = path, key, problem
        super().__init__(f"{path}: {key}: {problem}")


class InputError(VWorldLodError):
    """A tile folder (or an input file) that cannot be used at all."""


class ReadError(VWorldLodError):
    """One building's source file cannot be read: names the file and what is wrong.

    Raised by readers and binary parsers only as this type (never IndexError, struct.error, ...),
    so the pipeline can list the building in ``skipped`` and go on with the tile.
    """

    def __init__(self, path: str, problem: str) -> None:
        self.path, self.problem = str(path), problem
        super().__init__(f"{path}: {problem}")


class ProcessError(VWorldLodError):
    """A building read fine but a later stage (simplify, textures, write) failed for it."""
