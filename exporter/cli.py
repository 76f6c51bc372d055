"""The ``vworld-lod`` command line: export, init-config, inspect, report.

Exit codes: 0 success; 2 unusable input, config or output (one line on stderr naming the path and
the problem; also a usage error, with the likely verb or option); 130 interrupted (whatever was
written is complete; re-running resumes); 1 a bug (one line; ``--debug`` anywhere on the command
line, or ``VWORLD_LOD_DEBUG=1``, shows the traceback instead).
"""

from __future__ import annotations

import argparse
import dataclasses
import difflib
import errno
import os
import re
import sys
import time
from pathlib import Path
from typing import NoReturn, TextIO

from . import __version__
from .config import default_config_yaml, load_config, parse_crs_option
from .errors import InputError, ReadError, VWorldLodError
from .names import terminal_text

DEBUG_FLAG = "--debug"
DEBUG_ENV = "VWORLD_LOD_DEBUG"


class ProgressPrinter:
    """Buildings done / total with rate and ETA: a redrawn bar on a terminal, a plain line every
    few seconds otherwise (logs, CI)."""

    def __init__(self, stream: TextIO, interval_s: float = 5.0) -> None:
        self.stream = stream
        self.tty = stream.isatty()
        self.interval_s = interval_s
        self.started = time.monotonic()
        self.last = 0.0

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if not self.tty and done < total and now - self.last < self.interval_s:
            return
        self.last = now
        elapsed = max(now - self.started, 1e-9)
        rate = done / elapsed
        eta = (total - done) / rate if rate > 0 else 0.0
        text = f"{done}/{total} buildings  {rate:.1f}/s  ETA {int(eta) // 60}:{int(eta) % 60:02d}"
        if self.tty:
            width = 30
            filled = int(width * done / total) if total else width
            self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {text}  ")
            if done == total:
                self.stream.write("\n")
        else:
            self.stream.write(text + "\n")
        self.stream.flush()


CRS_OPTIONS = {"crs": "--crs", "override_crs": "--override-crs"}


def _effective_config(args):
    """The config file's settings with the command line's CRS options, each checked before any
    input is read (a typo is named as the option's, never blamed on an input file)."""
    config = load_config(args.config)
    for key, option in CRS_OPTIONS.items():
        value = getattr(args, key, None)
        if value is None:
            continue
        try:
            parse_crs_option(value)
        except ValueError as error:
            raise InputError(
                f"{option} {value}: {error}; give one PROJ knows, e.g. EPSG:7415"
            ) from None
        config.readers = dataclasses.replace(config.readers, **{key: value})
    return config


def _check_out(out: str) -> None:
    """Refuse an ``--out`` that cannot be an output folder before any input is read."""
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InputError(f"{path}: exists and is not a folder (--out takes a folder)")
    existing = next((p for p in [path, *path.parents] if p.exists()), Path("."))
    if not existing.is_dir():
        raise InputError(f"{existing}: not a folder, so {path} cannot be made in it")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"{existing}: not writable (permission denied)")


# Worker processes at most per core: more only add memory (each worker holds a building's
# meshes and atlases, ~80 MiB at the largest measured) and switching, no throughput.
JOBS_PER_CORE = 4


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells, else all)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def bounded_jobs(jobs: int | None, quiet: bool = False) -> int | None:
    """``--jobs`` capped at ``JOBS_PER_CORE`` x the usable cores, saying so on stderr."""
    limit = JOBS_PER_CORE * usable_cores()
    if jobs is None or jobs <= limit:
        return jobs
    if not quiet:
        print(
            f"vworld-lod: --jobs {jobs}: more than {JOBS_PER_CORE} per core ({usable_cores()} "
            f"cores) only costs memory; using {limit}",
            file=sys.stderr,
            flush=True,
        )
    return limit


def cmd_export(args) -> int:
    from .pipeline import export_tiles
    from .readers import input_paths

    _check_out(args.out)
    args.tile_dirs = input_paths(args.tile_dirs)
    config = _effective_config(args)
    jobs = bounded_jobs(args.jobs, args.quiet)
    progress = None if args.quiet else ProgressPrinter(sys.stderr)
    stats = export_tiles(
        args.tile_dirs,
        args.out,
        config,
        jobs=jobs,
        force=args.force,
        progress=progress,
        scheduler=args.scheduler,
        notify=None if args.quiet else lambda text: print(text, file=sys.stderr, flush=True),
    )
    sys.stderr.flush()  # the progress lines before the summary when both are captured
    for notice in stats.replaced:  # even with --quiet: another input's building is gone
        print(f"vworld-lod: {notice}", file=sys.stderr, flush=True)
    if not args.quiet:
        for tile in stats.tiles:
            print(
                f"{tile.tile.name}: {tile.buildings} building{'s' * (tile.buildings != 1)} "
                f"({tile.reused} unchanged), {tile.skipped} skipped -> {tile.manifest_path}"
            )
        if stats.tileset is not None:
            print(stats.tileset.summary())
        print(f"done in {stats.wall_seconds:.1f} s", flush=True)  # before any later stderr line
    if args.report:
        from .report import write_reports

        for page in write_reports(Path(args.out)):
            if not args.quiet:
                print(f"report: {page}", flush=True)
    return 0


def cmd_init_config(args) -> int:
    path = Path(args.path)
    if path.is_dir():
        print(
            f"vworld-lod: {path}: is a folder (give a file name, e.g. {path / 'lod.yaml'})",
            file=sys.stderr,
        )
        return 2
    if path.is_symlink() or (path.exists() and not path.is_file()):
        # The atomic write renames a new file over the name: a device (/dev/null, /dev/stdout),
        # a pipe or a link would be replaced by a regular file, not written to.
        return _fail(
            f"{path}: not a regular file (a link, device or pipe); init-config writes a new "
            "file only, never through such a name (give a file name)"
        )
    if path.exists() and not args.force:
        print(f"vworld-lod: {path}: already exists (use --force to overwrite)", file=sys.stderr)
        return 2
    from .atomic import write_text_atomic

    write_text_atomic(path, default_config_yaml())
    print(f"wrote {path}")
    return 0


def cmd_inspect(args) -> int:
    from .readers import check_crs_option, input_paths, load_entry, scan_folder

    args.tile_dirs = input_paths(args.tile_dirs)
    config = _effective_config(args)

    def write(line: str) -> None:  # ids, names and paths from input may hold escape sequences
        sys.stdout.write(terminal_text(line) + "\n")

    scans = [scan_folder(folder, config.readers) for folder in args.tile_dirs]
    check_crs_option(scans, config.readers)
    for folder, scan in zip(args.tile_dirs, scans):
        write(f"{folder}: format {scan.format}, {len(scan.entries)} buildings listed")
        for note in scan.notes:
            write(f"  note: {note}")
        tiles: dict[str, int] = {}
        triangles = 0
        textures = 0
        problems = [f"{item.source}: {item.reason}" for item in scan.skipped]
        for entry in scan.entries:
            try:
                building = load_entry(entry, config.readers)
            except ReadError as error:
                problems.append(str(error))
                continue
            tile = building.tile or entry.tile
            tiles[tile.name if tile else "?"] = tiles.get(tile.name if tile else "?", 0) + 1
            triangles += building.triangle_count
            atlases = [p.texture for p in building.parts if p.texture is not None]
            textures += len({id(t) for t in atlases})
            sizes = ", ".join(sorted({f"{t.width}x{t.height}" for t in atlases})) or "none"
            write(
                f"  {building.id}: {len(building.parts)} part(s), {building.triangle_count} triangles, textures {sizes}"
            )
            problems += [f"{building.id}: {p}" for p in building.problems]
        for name, count in sorted(tiles.items()):
            write(f"  tile {name}: {count} buildings")
        loaded = sum(tiles.values())
        write(
            f"  total: {loaded} buildings, {triangles} triangles"
            + (f" (mean {triangles / loaded:.1f})" if loaded else "")
            + f", {textures} textures"
        )
        write(f"  problems: {len(problems)}")
        for problem in problems:
            write(f"    {problem}")
    return 0


def cmd_report(args) -> int:
    from .report import write_reports

    for page in write_reports(Path(args.out)):
        print(f"report: {page}")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors that name the likely verb or option."""

    argv: list[str] = []  # the command line being parsed (set by main)

    def error(self, message: str) -> NoReturn:
        self.exit(
            2, f"{self.prog}: {message}{self._suggestion(message)} (see {self.prog} --help)\n"
        )

    def _suggestion(self, message: str) -> str:
        choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if choice:
            words = re.findall(r"'([^']*)'", choice.group(2)) or choice.group(2).split(", ")
            close = difflib.get_close_matches(choice.group(1), words, n=1)
            return f"; did you mean {close[0]!r}?" if close else ""
        # Unknown options: those argparse names, and those of the command line (an unknown option
        # may be reported as a missing required one, e.g. --ot for --out).
        unknown = re.search(r"unrecognized arguments: (.*)", message)
        words = (unknown.group(1).split() if unknown else []) + _Parser.argv
        known = self._options()
        hints = []
        for word in dict.fromkeys(w.split("=")[0] for w in words if w.startswith("--")):
            if word not in known and not any(k.startswith(word) for k in known):
                close = difflib.get_close_matches(word, known, n=1)
                hints += [f"{word}: did you mean {close[0]}?"] if close else []
        return "".join(f"; {hint}" for hint in hints)

    def _options(self) -> list[str]:
        """Option strings of this parser and its sub-commands."""
        found: list[str] = []
        for action in self._actions:
            found += action.option_strings
            for sub in (getattr(action, "choices", None) or {}).values():
                if isinstance(sub, argparse.ArgumentParser):
                    found += [o for a in sub._actions for o in a.option_strings]
        return sorted(set(found))


def _crs_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--crs",
        help="CRS of input files that do not declare one, e.g. EPSG:7415 (never overrides a "
        "declared one; refused when no input lacks one)",
    )
    parser.add_argument(
        "--override-crs",
        metavar="CRS",
        help="CRS that replaces the one every input file declares (noted in each building's "
        "problems and in the manifest's config)",
    )


INPUT_HELP = (
    "a tile folder (VWorld .dat/.xdo/.jpg, CityJSON, CityGML, OBJ/glTF with an index) or one "
    "file: *.city.json, *.json, *.city.jsonl, *.gml, *.gml.gz, a VWorld .dat, or an OBJ/glTF "
    "index (buildings.csv/.yaml/.json); shell globs are fine (each building is read once)"
)


def _debug_option(parser: argparse.ArgumentParser) -> None:
    """``--debug`` in the help (main() takes it out of the command line wherever it stands)."""
    parser.add_argument(
        DEBUG_FLAG,
        action="store_true",
        help=f"show the Python traceback of an internal error (exit 1) for a bug report; also "
        f"{DEBUG_ENV}=1",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="vworld-lod",
        description="Turn 3D building tiles into Unity-ready glTF LoD chains and a LODGroup manifest.",
    )
    parser.add_argument("--version", action="version", version=f"vworld-lod {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)

    export = commands.add_parser(
        "export", help="export tile folders to glTF LoD chains + lod_manifest.json per tile"
    )
    export.add_argument("tile_dirs", nargs="+", metavar="INPUT", help=INPUT_HELP)
    export.add_argument("--out", required=True, help="output folder (one subfolder per tile)")
    export.add_argument("--config", help="YAML config (see init-config); defaults from the paper")
    _crs_options(export)
    export.add_argument(
        "--jobs",
        type=int,
        default=None,
        help=f"worker processes (default: all cores; at most {JOBS_PER_CORE} per core)",
    )
    export.add_argument(
        "--force", action="store_true", help="redo every building, even unchanged ones"
    )
    export.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the per-building work on the Dask cluster at ADDRESS (tcp://host:8786), or "
        "'local' for a one-machine Dask cluster; needs vworld-lod[dask]",
    )
    export.add_argument("--quiet", action="store_true", help="print nothing but errors")
    _debug_option(export)
    export.add_argument(
        "--report", action="store_true", help="also write the HTML report (see 'report')"
    )
    export.set_defaults(run=cmd_export)

    init = commands.add_parser("init-config", help="write the default config as commented YAML")
    init.add_argument("path")
    init.add_argument("--force", action="store_true", help="overwrite an existing file")
    init.set_defaults(run=cmd_init_config)

    inspect = commands.add_parser("inspect", help="print what tile folders hold, writing nothing")
    inspect.add_argument("tile_dirs", nargs="+", metavar="INPUT", help=INPUT_HELP)
    inspect.add_argument("--config", help="YAML config (reader options)")
    _crs_options(inspect)
    _debug_option(inspect)
    inspect.set_defaults(run=cmd_inspect)

    report = commands.add_parser("report", help="write an HTML report of an export's LoD chains")
    report.add_argument("out", help="an export's output folder")
    report.set_defaults(run=cmd_report)
    return parser


def _fail(text: str, code: int = 2) -> int:
    # Always one line; a path or id from input cannot move the cursor or recolour the terminal.
    print(f"vworld-lod: {terminal_text(' '.join(text.split()))}", file=sys.stderr)
    return code


def _os_problem(error: OSError) -> str:
    """One line for an OSError: the path, the system's reason and, for a full disk, what to do."""
    where = error.filename if error.filename is not None else "?"
    text = f"{where}: {error.strerror or error}"
    if error.errno in (errno.ENOSPC, errno.EDQUOT):
        text += "; free some space and re-run to finish (completed files are kept)"
    return text


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = DEBUG_FLAG in argv or os.environ.get(DEBUG_ENV, "") not in ("", "0")
    argv = [a for a in argv if a != DEBUG_FLAG]
    try:
        _Parser.argv = argv
        args = build_parser().parse_args(argv)

        if getattr(args, "jobs", None) is not None and args.jobs < 1:
            return _fail("--jobs: must be at least 1")
        return args.run(args)
    except KeyboardInterrupt:
        if debug:
            raise
        _fail("interrupted; finished files are complete, re-run to resume")
        return 130
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except Exception as error:
        if debug:
            raise
        if isinstance(error, VWorldLodError):
            return _fail(str(error))
        if isinstance(error, OSError):
            return _fail(_os_problem(error))
        if isinstance(error, MemoryError):
            return _fail("out of memory (try fewer --jobs)")
        return _fail(
            f"internal error: {type(error).__name__}: {error} (re-run with {DEBUG_FLAG} or "
            f"{DEBUG_ENV}=1 for the traceback, and please report it)",
            code=1,
        )
