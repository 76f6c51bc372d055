"""Is the service at a ``--scheduler`` address a Dask scheduler? A bounded check before Dask's client.

Dask's client trusts the first bytes it gets: a service that is not Dask makes it hang (an HTTP
server waits for a request and never speaks first) or read a banner's text as a frame length and
allocate that much (an SSH server's ``SSH-2.0-…``: a ``MemoryError``, reported as "out of memory").

A Dask scheduler writes its handshake as soon as a connection is accepted (measured on
distributed 2024-2025: 66 bytes within a millisecond): Dask's TCP framing is a little-endian uint64
byte count of the message, then the frame count and frame lengths (uint64 each), then the frames,
here a msgpack map with ``compression``, ``python`` and ``pickle-protocol``
(``distributed/comm/tcp.py``, ``distributed/comm/core.py``: ``Comm.handshake_info``). This module
connects, reads that message within a time limit and refuses anything else with a one-line reason.
Plain ``tcp://`` addresses only (``tls://`` and others are left to Dask).
"""

from __future__ import annotations

import socket
import struct
import time

# A handshake is a few dozen bytes; anything claiming more than this is not one.
MAX_HANDSHAKE_BYTES = 1 << 16
HANDSHAKE_KEY = b"pickle-protocol"  # a key of every Dask handshake (Comm.handshake_info)


class NotDask(Exception):
    """The service at the address answered, but not as a Dask scheduler (the text says how)."""


def tcp_host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a ``tcp://host:port`` or bare ``host:port`` address, else None (other
    schemes, or no port: Dask's default port then applies and Dask checks it itself)."""
    if "://" in address:
        scheme, _, location = address.partition("://")
        if scheme != "tcp":
            return None
    else:
        location = address
    host, sep, port = location.rpartition(":")
    if not sep or not port.isdigit():
        return None
    return host.strip("[]"), int(port)


def _shown(data: bytes) -> str:
    """The first bytes a service sent, readable (printable ASCII kept, the rest escaped)."""
    return repr(data[:40].decode("ascii", "backslashreplace"))


def read_handshake(sock: socket.socket, timeout_s: float) -> bytes:
    """Dask's first message on ``sock`` (its byte count excluded), read within ``timeout_s``
    seconds in all; raises NotDask for silence, a closed connection or bytes that are not one."""
    deadline = time.monotonic() + timeout_s
    data = b""
    need = 8
    while len(data) < need:
        left = deadline - time.monotonic()
        if left <= 0:
            break
        sock.settimeout(left)
        try:
            chunk = sock.recv(max(need - len(data), 64))  # 64: enough of a banner to show
        except TimeoutError:
            break
        if not chunk:
            raise NotDask(
                "closed the connection without a Dask handshake"
                + (f" (it sent {_shown(data)})" if data else "")
            )
        data += chunk
        if len(data) >= 8 and need == 8:
            (size,) = struct.unpack("<Q", data[:8])
            if not 16 <= size <= MAX_HANDSHAKE_BYTES:
                raise NotDask(f"sent {_shown(data)}, not a Dask handshake")
            need = 8 + size
    if len(data) < need:
        raise NotDask(
            f"sent no Dask handshake within {timeout_s:g} s"
            + (f" (only {_shown(data)})" if data else " (a Dask scheduler speaks first)")
        )
    if HANDSHAKE_KEY not in data:
        raise NotDask(f"sent {_shown(data)}, not a Dask handshake")
    return data[8:]


def check_dask_scheduler(address: str, timeout_s: float) -> None:
    """Raise NotDask when the plain-TCP service at ``address`` is not a Dask scheduler (within
    ``timeout_s`` seconds for connecting and for the handshake each); OSError when it cannot be
    reached. Other addresses are left to Dask."""
    host_port = tcp_host_port(address)
    if host_port is None:
        return
    with socket.create_connection(host_port, timeout=timeout_s) as sock:
        read_handshake(sock, timeout_s)
