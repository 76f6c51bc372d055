"""Pool workers that end when the exporting process dies, by any signal (SIGKILL included).

A ``ProcessPoolExecutor`` worker blocks on its task queue; when its parent is killed outright (a
job scheduler's time limit, the OOM killer, ``timeout -s KILL``) nothing tells it, and it would
stay, holding its memory, until killed by hand. :func:`start_worker` (the pool's initializer)
makes each worker end with the exporting process in two ways:

- Linux: ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` (through ctypes): the kernel kills the worker when
  the thread that started it exits.
- Everywhere (macOS, other start methods): a daemon thread that looks every ``WATCH_S`` seconds
  whether the worker was re-parented or the exporting process is gone, and then ends the worker.

Nothing is left half-written: every output file is written under a temporary name and renamed
(``exporter.atomic``); a re-run removes the temporaries and resumes.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os
import signal
import sys
import threading
import time

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
WATCH_S = 0.5  # seconds between the watchdog's looks at the parent
EXIT_CODE = 70  # EX_SOFTWARE: the worker's parent is gone


def start_worker(parent_pid: int) -> None:
    """Pool initializer: tie this worker's life to the process ``parent_pid`` (module doc), and
    keep its collector off what it inherited."""
    # A forked worker inherits the exporting process's objects (entries, records: 10^5 and more).
    # Frozen, the collector never walks them: each full collection a task's JSON parsing sets off
    # would otherwise traverse them all and copy their pages (0.04 s of a 0.4 s proxy).
    gc.freeze()
    if sys.platform.startswith("linux"):
        _kill_me_with_parent()
    if not parent_alive(parent_pid):  # died before the line above took effect
        os._exit(EXIT_CODE)
    watchdog = threading.Thread(
        target=_watch, args=(parent_pid, os.getppid()), name="vworld-lod-parent-watch", daemon=True
    )
    watchdog.start()


def _kill_me_with_parent() -> None:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # no libc prctl: the watchdog alone does it
        pass


def parent_alive(pid: int) -> bool:
    """True while process ``pid`` exists (a signal 0 reaches it)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by another user (the pid was reused)
        return False
    return True


def _watch(parent_pid: int, ppid: int) -> None:
    """End this process when it is re-parented (its parent exited) or ``parent_pid`` is gone."""
    while os.getppid() == ppid and parent_alive(parent_pid):
        time.sleep(WATCH_S)
    os._exit(EXIT_CODE)
