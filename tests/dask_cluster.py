"""A real Dask cluster for tests and benchmarks: ``dask scheduler`` and ``dask worker`` as separate
processes on loopback, random ports, this checkout on their PYTHONPATH; every process it starts is
stopped by ``close()`` (also on failure), so nothing leaks."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _dask_command(*args: str) -> list[str]:
    """``dask <args>`` run by this interpreter (no reliance on PATH)."""
    return [
        sys.executable,
        "-c",
        "import sys; from dask.__main__ import main; sys.exit(main())",
        *args,
    ]


class DaskCluster:
    """``with DaskCluster(folder, workers=2) as cluster: cluster.address``.

    Workers run without a nanny (``--no-nanny``), so killing one (``kill_worker``) removes it for
    good, as a machine lost mid-run would."""

    def __init__(
        self,
        folder: Path,
        workers: int = 2,
        env: dict | None = None,
        cpus: list[int] | None = None,
    ) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
            **(env or {}),
        }
        self.cpus = cpus
        self.processes: list[subprocess.Popen] = []
        self.logs: list = []
        self.workers: list[subprocess.Popen] = []
        self.scheduler_file = self.folder / "scheduler.json"
        self.address = ""
        try:
            self._start_scheduler()
            for _ in range(workers):
                self.start_worker()
            if workers:
                self.wait_for_workers(workers)
        except BaseException:
            self.close()
            raise

    def _spawn(self, args: list[str], log: str, env: dict | None = None) -> subprocess.Popen:
        command = _dask_command(*args)
        if self.cpus is not None and hasattr(os, "sched_setaffinity"):
            command = ["taskset", "-c", ",".join(map(str, self.cpus)), *command]
        stderr = open(self.folder / log, "ab")
        self.logs.append(stderr)
        process = subprocess.Popen(
            command,
            cwd=self.folder,
            env=env or self.env,
            stdout=subprocess.DEVNULL,
            stderr=stderr,
            start_new_session=True,  # a Ctrl-C in the test's terminal does not reach them
        )
        self.processes.append(process)
        return process

    def _start_scheduler(self) -> None:
        self._spawn(
            [
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--dashboard-address",
                "127.0.0.1:0",
                "--scheduler-file",
                str(self.scheduler_file),
            ],
            "scheduler.log",
        )
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                self.address = json.loads(self.scheduler_file.read_text())["address"]
                return
            except (OSError, ValueError, KeyError):
                time.sleep(0.05)
        raise RuntimeError(f"dask scheduler did not start: {self.log('scheduler.log')}")

    def start_worker(self, env: dict | None = None) -> subprocess.Popen:
        index = len(self.workers)
        process = self._spawn(
            [
                "worker",
                self.address,
                "--nthreads",
                "1",
                "--no-nanny",
                "--host",
                "127.0.0.1",
                "--no-dashboard",
                "--name",
                f"w{index}",
                "--local-directory",
                str(self.folder / f"w{index}"),
            ],
            f"worker{index}.log",
            env,
        )
        self.workers.append(process)
        return process

    def worker_count(self) -> int:
        from distributed import Client

        with Client(self.address, timeout=10) as client:
            return len(client.scheduler_info(n_workers=-1)["workers"])

    def wait_for_workers(self, count: int, timeout: float = 60) -> None:
        from distributed import Client

        with Client(self.address, timeout=10) as client:
            client.wait_for_workers(count, timeout=timeout)

    def kill_worker(self, index: int = 0) -> None:
        process = self.workers[index]
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=10)

    def log(self, name: str) -> str:
        try:
            return (self.folder / name).read_text(errors="replace")[-3000:]
        except OSError:
            return ""

    def close(self) -> None:
        for process in reversed(self.processes):
            if process.poll() is None:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + 1  # a graceful stop, else killed
        for process in self.processes:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait(timeout=10)
        for handle in self.logs:
            handle.close()

    def __enter__(self) -> DaskCluster:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
