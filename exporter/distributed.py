"""The export's per-building work on a Dask cluster (``vworld-lod export … --scheduler ADDRESS``).

Data form: the same work items as the local pool (``(entry, config, out_dir, digest,
fingerprints)`` tuples for :func:`exporter.job.process_entry`) go to the cluster in batches
(:func:`process_batch`, one Dask task each); each task returns the batch's
:class:`~exporter.job.EntryResult` list. Workers write every building's files themselves
(atomically, record last), so the client only collects results and writes the manifests, exactly as
with the local pool: the output is byte-identical to a local run.

Steps of :func:`cluster_session` (before any work): connect (bounded:
``ClusterOptions.connect_timeout_s``) -> wait a bounded time for at least one worker -> refuse
workers (or a scheduler) whose versions differ from the client's (Python, this package and a hash
of its code, the key dependencies) -> a probe on every worker that it sees the inputs as the
client does (a folder's file names, a file's size) and writes into the output folder (a file the
client then finds). Relative paths work from the client's working folder on the workers.

Failures: a worker lost mid-run costs its tasks in flight; the scheduler re-runs them elsewhere,
at most ``distributed.scheduler.allowed-failures`` times before the run stops with a one-line
error; a lost scheduler, or a cluster left without workers for ``WORKER_WAIT_S``, stops the run
with a one-line error. Either way the finished buildings
stay (a record is written after its files), no manifest is half-written, and re-running resumes.

Dask's documentation: https://distributed.dask.org/en/stable/ (Client, LocalCluster,
as_completed, get_versions, resilience).
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import os
import platform
import signal
import threading
import time
import uuid
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from functools import cache
from importlib import metadata
from pathlib import Path
from typing import Any

from . import __version__
from .errors import VWorldLodError
from .job import process_entry
from .scheduler_probe import NotDask, check_dask_scheduler

DASK_MISSING = (
    "--scheduler needs dask and distributed, which are not installed: "
    "pip install 'vworld-lod[dask]'"
)

# Buildings per task, chosen by benchmarks/bench_distributed.py (docs/performance.md): a
# task cost 7-11 ms of client + scheduler time on loopback against 38-135 ms of work per building
# (both measured on 2 loaded cores), so 16 buildings keep the overhead near 1 % while a lost
# worker costs little (16 x ~23 ms unloaded).
BATCH_SIZE = 16
# Batches in flight per worker: one running, one queued, so no worker waits for the client.
IN_FLIGHT_PER_WORKER = 2
# Seconds to wait for the first worker to join before giving up.
WORKER_WAIT_S = 60.0
# Seconds between looks at the worker count during a run, and between polls for finished batches.
WORKER_CHECK_S = 2.0
POLL_S = 0.01
# Seconds to keep trying to reach the scheduler (dask's own default, 30 s, is long for a typo).
CONNECT_TIMEOUT_S = 10.0

# Distributions whose version must be the same on the client, the scheduler (for the first three)
# and every worker: the Dask stack, then everything the per-building work uses.
DASK_PACKAGES = ("dask", "distributed", "cloudpickle", "msgpack")
WORK_PACKAGES = (
    "numpy",
    "scipy",
    "trimesh",
    "pymeshlab",
    "Pillow",
    "pygltflib",
    "PyYAML",
    "pyproj",
    "mapbox-earcut",
    "meshoptimizer",
)


class ClusterError(VWorldLodError):
    """The cluster cannot run the export: unreachable, no workers, mismatched, lost, ..."""


@dataclass
class ClusterOptions:
    """Where and how to run: ``address`` is ``tcp://host:port`` of a running scheduler, or
    ``"local"`` for a :class:`distributed.LocalCluster` of ``local_workers`` one-thread worker
    processes (default: all cores)."""

    address: str
    batch_size: int = BATCH_SIZE
    worker_wait_s: float | None = None  # None: WORKER_WAIT_S
    connect_timeout_s: float | None = None  # None: CONNECT_TIMEOUT_S
    local_workers: int | None = None


# --------------------------------------------------------------------------- identities


@cache
def code_hash() -> str:
    """sha256 (16 hex digits) of this package's source and data files: two installs with the same
    version number but edited code differ here."""
    root = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".py", ".json", ".yaml") and "__pycache__" not in path.parts:
            digest.update(path.relative_to(root).as_posix().encode() + b"\0")
            digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def identity() -> dict[str, str]:
    """What must match between the client and every worker: ``{name: version}``, with
    ``"-"`` for a distribution that is not installed."""
    versions = {
        "python": platform.python_version(),
        "vworld-lod": __version__,
        "vworld-lod code": code_hash(),
    }
    for name in DASK_PACKAGES + WORK_PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "-"
    return versions


def version_mismatches(mine: dict[str, str], theirs: dict[str, dict[str, str]]) -> list[str]:
    """One text per machine that differs from ``mine``: ``"worker tcp://…: numpy 1.26.4 (client
    2.1.0)"``; ``theirs`` maps a worker (or ``"scheduler"``) to its :func:`identity` (the
    scheduler's may hold only some names: only those are compared)."""
    out = []
    for who, versions in sorted(theirs.items()):
        diffs = [
            f"{name} {versions[name]} (client {mine.get(name, '-')})"
            for name in mine
            if name in versions and versions[name] != mine[name]
        ]
        if diffs:
            out.append(f"{who}: {', '.join(diffs)}")
    return out


# --------------------------------------------------------------------------- storage probe


def listing_digest(path: str) -> str | None:
    """What a machine sees of an input: for a folder, sha256 of its sorted file names; for a
    file, sha256 of its size; None when it cannot be read."""
    try:
        if os.path.isdir(path):
            text = "\0".join(sorted(os.listdir(path)))
        else:
            text = f"file of {os.stat(path).st_size} bytes"
    except OSError:
        return None
    return hashlib.sha256(text.encode()).hexdigest()


def enter_client_folder(cwd: str) -> None:
    """Make the client's working folder this worker's, so that paths behave as on the client
    (relative ones included: the manifest records input paths as the user wrote them)."""
    if os.getcwd() != cwd:
        os.chdir(cwd)


def probe_storage(inputs: dict[str, str | None], out_dir: str, token: str, cwd: str) -> str | None:
    """Run on a worker: None when it sees every input (folder or file) as the client does
    (``inputs``: path -> :func:`listing_digest` on the client) and can write into ``out_dir``
    (it leaves ``out_dir/.probe-<token>-<random>.tmp`` for the client to find); else the problem.
    Relative paths are the client's, from ``cwd``."""
    try:
        enter_client_folder(cwd)
    except OSError:
        if not all(os.path.isabs(path) for path in [*inputs, out_dir]):
            return (
                f"cannot see the client's working folder {cwd} (give absolute paths, or share it)"
            )
    for folder, expected in inputs.items():
        seen = listing_digest(folder)
        if seen is None:
            return f"cannot read the input {folder}"
        if seen != expected:
            return f"sees another {folder} than the client (not shared?)"
    probe = os.path.join(out_dir, f".probe-{token}-{uuid.uuid4().hex[:8]}.tmp")
    try:
        with open(probe, "w", encoding="utf-8") as handle:
            handle.write(token)
    except OSError as error:
        return f"cannot write into the output folder {out_dir} ({error.strerror or error})"
    return None


def _probe_files(out_dir: str, token: str) -> list[Path]:
    return list(Path(out_dir).glob(f".probe-{token}-*.tmp"))


# --------------------------------------------------------------------------- the work


class StorageLost(Exception):
    """Raised in a task whose worker no longer sees the shared input or output folder."""


def process_batch(items: list[tuple], cwd: str) -> list:
    """Run on a worker: :func:`exporter.job.process_entry` for every item, from the client's
    working folder ``cwd``, after checking that the shared folders are still there (a worker that
    lost its mount must fail loudly, not report every building as missing). Workers are meant to
    run one thread each (the work is CPU-bound); with more, all of this export's tasks set the
    same folder."""
    try:
        enter_client_folder(cwd)
    except OSError:
        pass  # absolute paths do not need it; relative ones fail the check below
    folders = {item[2] for item in items}
    folders |= {os.path.dirname(name) or "." for item in items for name in item[0].inputs}
    for folder in sorted(folders):
        if not os.path.isdir(folder):
            raise StorageLost(f"worker {_worker_address()}: cannot see {folder}")
    return [process_entry(*item) for item in items]


def load_native_libraries() -> None:
    """Import pymeshlab in the calling thread. Run in each worker's main thread before any task:
    pymeshlab initialised first from a task thread corrupts the heap at process exit
    (glibc's "malloc_consolidate(): unaligned fastbin chunk detected", ~3 of 4 runs measured)."""
    import pymeshlab  # noqa: F401


def _worker_setup_plugin():
    """A :class:`distributed.WorkerPlugin` running :func:`load_native_libraries` on every worker,
    including those that join later (plugins' ``setup`` runs on the worker's event loop, in its
    main thread)."""
    from distributed import WorkerPlugin

    class LoadNativeLibraries(WorkerPlugin):
        name = "vworld-lod-load-native-libraries"

        def setup(self, worker) -> None:
            load_native_libraries()

    return LoadNativeLibraries()


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"{platform.node()} pid {os.getpid()}"


# --------------------------------------------------------------------------- the session


def _require_dask():
    try:
        import distributed
    except ImportError as error:
        raise ClusterError(DASK_MISSING) from error
    return distributed


@contextmanager
def cluster_session(options: ClusterOptions, folders: list[str], out_dir: str, notify=None):
    """A checked :class:`distributed.Client` (see the module doc for the checks), closed on exit
    (with the local cluster it started, if any). ``notify(text)`` gets the dashboard address."""
    distributed = _require_dask()
    notify = notify or (lambda text: None)
    cluster = None
    client = None
    # Dask's client logs its reconnection attempts with tracebacks; the run reports what happened
    # in one line instead (the scheduler's and workers' own logs keep the details).
    loggers = [logging.getLogger(name) for name in _dask_logger_names()]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL)
    try:
        if options.address == "local":
            with _sigint_ignored():  # inherited: Ctrl-C stops the client, which stops them
                cluster = distributed.LocalCluster(
                    n_workers=options.local_workers or os.cpu_count() or 1,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=":0",
                    silence_logs=40,  # logging.ERROR: the run's own progress line stays readable
                )
            client = distributed.Client(cluster)
        else:
            timeout_s = options.connect_timeout_s or CONNECT_TIMEOUT_S
            try:
                # Dask's client hangs on a service that does not speak first (HTTP) and reads a
                # banner (SSH) as a frame length: the address is checked first (scheduler_probe).
                check_dask_scheduler(options.address, timeout_s)
                client = distributed.Client(options.address, timeout=timeout_s)
            except NotDask as error:
                raise ClusterError(
                    f"{options.address} is not a Dask scheduler: it {error}; give the address "
                    "`dask scheduler` prints (tcp://host:8786)"
                ) from None
            except (OSError, TimeoutError, ValueError) as error:
                raise ClusterError(
                    f"cannot reach the Dask scheduler {options.address}: {_one_line(error)}"
                ) from None
        if client.dashboard_link:
            notify(f"dask dashboard: {client.dashboard_link}")
        wait_s = options.worker_wait_s or WORKER_WAIT_S
        try:
            client.wait_for_workers(1, timeout=wait_s)
        except (TimeoutError, distributed.TimeoutError):
            raise ClusterError(
                f"the Dask scheduler {options.address} has no workers (waited {wait_s:g} s); "
                f"start some with `dask worker {options.address}`"
            ) from None
        check_versions(client)
        client.register_plugin(_worker_setup_plugin())
        check_storage(client, folders, out_dir)
        yield client
    finally:
        try:
            if client is not None:
                client.close(timeout=5)
            if cluster is not None:
                cluster.close(timeout=5)
        finally:
            for logger, level in zip(loggers, levels):
                logger.setLevel(level)


@contextmanager
def _sigint_ignored():
    """SIGINT ignored while the local cluster's worker processes start, so that they inherit it:
    a terminal's Ctrl-C reaches the whole process group, and workers that got it would print
    tracebacks while the client shuts them down."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: signals are not ours to change
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _dask_logger_names() -> list[str]:
    names = [name for name in logging.root.manager.loggerDict if name.startswith("distributed")]
    return ["distributed", *names]


def check_versions(client) -> None:
    """Refuse workers (and a scheduler) whose :func:`identity` differs from the client's."""
    mine = identity()
    theirs = {}
    unusable = []
    for who, found in client.run(identity, on_error="return").items():
        if isinstance(found, BaseException):  # e.g. vworld-lod not installed there
            unusable.append(f"worker {who}: cannot run vworld-lod ({_one_line(found)})")
        else:
            theirs[f"worker {who}"] = found
    if unusable:
        raise ClusterError("; ".join(unusable))
    scheduler = client.get_versions(packages=list(DASK_PACKAGES))["scheduler"]
    theirs["scheduler"] = {
        name: str(version)
        for name, version in scheduler["packages"].items()
        if name in ("dask", "distributed") and version is not None
    }
    problems = version_mismatches(mine, theirs)
    if problems:
        raise ClusterError(
            "the cluster runs other versions than this client; install the same on every "
            "machine: " + "; ".join(problems)
        )


def check_storage(client, folders: list[str], out_dir: str) -> None:
    """Every worker sees the input folders and writes where the client reads (module doc)."""
    inputs = {folder: listing_digest(folder) for folder in folders}
    token = uuid.uuid4().hex[:12]
    try:
        found = client.run(probe_storage, inputs, out_dir, token, os.getcwd(), on_error="return")
        problems = [
            f"worker {who}: {_one_line(problem) if isinstance(problem, BaseException) else problem}"
            for who, problem in found.items()
            if problem
        ]
        if not problems and len(_probe_files(out_dir, token)) < len(set(found)):
            problems.append(
                f"a worker wrote its probe file into its own {out_dir}, which this client does not "
                "see: the output folder must be shared storage mounted at the same path"
            )
    finally:
        for probe in _probe_files(out_dir, token):
            probe.unlink(missing_ok=True)
    if problems:
        raise ClusterError("; ".join(problems))


def batch_size_for(total: int, workers: int, largest: int) -> int:
    """Buildings per task: ``largest``, smaller for small runs so every worker gets at least four
    batches (an even finish)."""
    return max(1, min(largest, math.ceil(total / (4 * max(1, workers)))))


def cluster_results(client, work: Iterable, total: int, options: ClusterOptions) -> Iterator:
    """Run the work items of ``work`` (tuples, or finished results passed through) on the
    cluster in batches, a bounded number in flight; yields each
    :class:`~exporter.job.EntryResult` as its batch finishes."""
    from distributed import KilledWorker, as_completed
    from distributed.utils import CancelledError

    workers = max(1, len(client.nthreads()))
    size = batch_size_for(total, workers, options.batch_size)
    wait_s = options.worker_wait_s or WORKER_WAIT_S
    cwd = os.getcwd()
    running = as_completed()
    submitted = set()
    batch: list[tuple] = []
    # The worker count, looked up every few seconds: it sets how many batches are in flight
    # (workers may join, e.g. an adaptive dask-jobqueue cluster) and notices a cluster left with
    # none (its batches would wait forever).
    checked = with_workers = time.monotonic()

    def count_workers() -> int:
        nonlocal workers, checked, with_workers
        now = time.monotonic()
        if now - checked >= WORKER_CHECK_S:
            checked = now
            try:
                workers = len(client.nthreads())
            except OSError as error:
                raise lost_scheduler(error) from None
            if workers:
                with_workers = now
            elif now - with_workers > wait_s:
                raise ClusterError(
                    f"every worker of {options.address} left mid-run and none came back in "
                    f"{wait_s:g} s; finished buildings are kept, re-run to resume"
                )
        return workers

    def lost_scheduler(error: BaseException) -> ClusterError:
        return ClusterError(
            f"lost the Dask scheduler {options.address} mid-run ({_one_line(error)}); "
            "finished buildings are kept, re-run to resume"
        )

    def submit(items: list[tuple]) -> None:
        future = client.submit(process_batch, items, cwd, pure=False)
        submitted.add(future)
        running.add(future)

    def next_finished():
        while not running.has_ready():
            time.sleep(POLL_S)
            count_workers()
        return next(running)

    def collect(future) -> list:
        submitted.discard(future)
        try:
            return future.result()
        except KilledWorker as error:
            raise ClusterError(
                "workers died running the same buildings again and again "
                f"({_one_line(error)}); finished buildings are kept, re-run to resume"
            ) from None
        except StorageLost as error:
            raise ClusterError(str(error)) from None
        except (CancelledError, OSError) as error:
            raise lost_scheduler(error) from None

    try:
        for item in work:
            if not isinstance(item, tuple):
                yield item
                continue
            batch.append(item)
            if len(batch) >= size:
                submit(batch)
                batch = []
                while running.count() >= IN_FLIGHT_PER_WORKER * max(1, count_workers()):
                    yield from collect(next_finished())
        if batch:
            submit(batch)
        while not running.is_empty():
            yield from collect(next_finished())
    finally:
        if submitted:  # stopped early (an error, Ctrl-C): workers drop what has not started
            client.cancel(list(submitted))


# --------------------------------------------------------------------------- the tileset's proxies


class ProxyWorkers:
    """Where the export's tail builds the tileset's proxies (:mod:`exporter.tileset.schedule`):
    this process (one job), a local process pool of ``jobs`` workers, or the Dask cluster of
    ``cluster`` (:class:`ClusterOptions`; one task per proxy, after the same checks as the
    buildings' session, ``folders`` being the run's inputs). The pool or session starts at the
    first proxy to build and ends on :meth:`close`. With more than one job even a level's single
    proxy goes to a worker: a proxy's atlases and meshes (~60 MB for a level-12 parent of 2048 px
    atlases) then never raise the main process's peak."""

    def __init__(
        self,
        jobs: int = 1,
        cluster: ClusterOptions | None = None,
        folders: list[str] | None = None,
        notify=None,
    ) -> None:
        self.jobs = max(1, jobs)
        self.cluster = cluster
        self.folders = folders or []
        self.notify = notify
        self._stack = ExitStack()
        # the proxies built ahead (exporter.completion.Overlap.speculate) share it from a thread
        self._lock = threading.Lock()
        self._pool: ProcessPoolExecutor | None = None
        self._client: Any = None
        self._shared: Any = None
        self.remote = 0  # proxies built on pool or cluster workers (what the benchmark shows)

    def map(self, function, items: list, out_dir: str) -> list:
        """``[function(item) for item in items]``, in order, where this runs them."""
        if not items:
            return []
        if self.cluster is not None:
            client = self._session(out_dir)
            self.remote += len(items)
            return client.gather(client.map(function, items, pure=False))
        if self.jobs == 1:
            return [function(item) for item in items]
        with self._lock:
            self.remote += len(items)
        return list(self._local_pool().map(function, items))

    def submit(self, function, item, out_dir: str) -> Any:
        """``function(item)`` started where this runs it, not waited for: a future (its
        ``result()`` waits); with one job it runs here, now."""
        if self.cluster is not None:
            self.remote += 1
            return self._session(out_dir).submit(function, item, pure=False)
        if self.jobs == 1:
            future: Future = Future()
            future.set_result(function(item))
            return future
        with self._lock:
            self.remote += 1
        return self._local_pool().submit(function, item)

    def share(self, client: Any) -> None:
        """Run on ``client`` (the buildings' checked session: no second session, and with
        ``--scheduler local`` no second cluster, while the buildings are made) until
        ``share(None)``; then a session of its own as before."""
        self._shared = client

    def _session(self, out_dir: str) -> Any:
        assert self.cluster is not None
        if self._shared is not None:
            return self._shared
        if self._client is None:
            session = cluster_session(self.cluster, self.folders, out_dir, self.notify)
            self._client = self._stack.enter_context(session)
        return self._client

    def _local_pool(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._pool is None:
                from .workers import start_worker

                self._pool = self._stack.enter_context(
                    ProcessPoolExecutor(
                        max_workers=self.jobs, initializer=start_worker, initargs=(os.getpid(),)
                    )
                )
            return self._pool

    def close(self) -> None:
        self._stack.close()


def cluster_options(scheduler: str | ClusterOptions | None, jobs: int) -> ClusterOptions | None:
    """``scheduler`` (an address, ``"local"`` or ClusterOptions) as ClusterOptions, a local
    cluster getting ``jobs`` workers as the building work's does; None without one."""
    if scheduler is None:
        return None
    options = scheduler if isinstance(scheduler, ClusterOptions) else ClusterOptions(scheduler)
    if options.address == "local" and options.local_workers is None:
        options = dataclasses.replace(options, local_workers=jobs)
    return options


def _one_line(error: BaseException) -> str:
    text = " ".join(str(error).split())
    return text or type(error).__name__
