"""Bytes the stack's TCP sockets moved, from the kernel's own per-socket counters.

The thesis measured its network load with nload (table 4.10): every byte every hop put on
the interface. The honest counterpart on one host is the kernel's count per TCP socket
(``tcp_info.bytes_sent``, as ``ss -tinp`` prints it) for the sockets of the stack's processes:
it counts every hop once (by its sender), every op, frame and telemetry batch, and nothing of
other programs on the machine (which ``lo``'s counters include). TCP/IP headers are not
counted (on loopback one 64 KiB segment carries ~66 B of them). Parsing is pure; the caller
runs ``ss`` (``SS_COMMAND``) at the window's start and end.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

SS_COMMAND = ("ss", "-tinpH", "state", "established")
_PIDS = re.compile(r"pid=(\d+)")
_COUNTER = re.compile(r"\b(bytes_sent|bytes_received):(\d+)")


@dataclass(frozen=True)
class SocketBytes:
    """One established TCP socket: the processes holding it, its ends, its byte counters."""

    pids: tuple[int, ...]
    local: str
    peer: str
    bytes_sent: int = 0
    bytes_received: int = 0


def parse_ss(text: str) -> list[SocketBytes]:
    """Sockets of ``ss -tinpH state established`` output: a line with the queues, the two
    addresses and the owning processes, then an indented line of tcp_info counters."""
    sockets: list[SocketBytes] = []
    head: list[str] | None = None
    for line in text.splitlines():
        if not line.strip():
            continue
        if not line[0].isspace():
            if head is not None:
                sockets.append(_socket(head, ""))
            head = line.split()
        elif head is not None:
            sockets.append(_socket(head, line))
            head = None
    if head is not None:
        sockets.append(_socket(head, ""))
    return [s for s in sockets if s.local]


def _socket(fields: list[str], info: str) -> SocketBytes:
    if len(fields) < 4:
        return SocketBytes((), "", "")
    pids = tuple(int(p) for p in _PIDS.findall(" ".join(fields[4:])))
    counters = {name: int(value) for name, value in _COUNTER.findall(info)}
    return SocketBytes(
        pids, fields[2], fields[3], counters.get("bytes_sent", 0), counters.get("bytes_received", 0)
    )


@dataclass(frozen=True)
class SocketTraffic:
    """What the stack's sockets sent in a window: in all, to the measuring processes (apart),
    per stack process; and how many of the stack's sockets were seen."""

    stack_bytes: int
    instrument_bytes: int
    by_process: Mapping[str, int]
    sockets: int


def window_traffic(
    before: Iterable[SocketBytes],
    after: Iterable[SocketBytes],
    stack_pids: Mapping[int, str],
    instrument_pids: Iterable[int],
) -> SocketTraffic | None:
    """What the stack's sockets sent between two snapshots.

    stack_pids : pid -> process name of the stack (bridge, simulator, navigation).
    instrument_pids : the measuring processes (the report): bytes the stack sent to them are
    counted apart, as ``instrument_bytes``. A socket opened during the window counts from 0;
    one closed during it is missing from ``after`` and not counted (the stack keeps its
    connections for its lifetime). Returns None when no socket of the stack was seen (the
    stack runs on another host or in other pid namespaces).
    """
    instruments = set(instrument_pids)
    start = {(s.local, s.peer): s.bytes_sent for s in before}
    mine = [s for s in after if set(s.pids) & set(stack_pids)]
    if not mine:
        return None
    instrument_ends = {s.local for s in after if set(s.pids) & instruments}
    by_process: dict[str, int] = {}
    stack = to_instrument = 0
    for sock in mine:
        sent = sock.bytes_sent - start.get((sock.local, sock.peer), 0)
        if sock.peer in instrument_ends:
            to_instrument += sent
            continue
        stack += sent
        name = next(stack_pids[p] for p in sock.pids if p in stack_pids)
        by_process[name] = by_process.get(name, 0) + sent
    return SocketTraffic(stack, to_instrument, dict(sorted(by_process.items())), len(mine))
