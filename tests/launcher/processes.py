"""The launcher tests' view of `riverbridge up`: its announcements and what it leaves behind.

The generic child-process handling lives in tests/child_process.py (shared with the simulator
tests and the benchmarks); this adds `up`'s own output lines and orphan checks.
"""

from __future__ import annotations

import os
import re
import signal
import sys
import time
from collections.abc import Sequence

from tests.child_process import STARTUP_TIMEOUT_S, Running, pid_alive

_STARTED = re.compile(r"\[up\]\s+started (?P<title>\w+) \(pid (?P<pid>\d+)\)")
_CONNECT = re.compile(r"connect to (?P<url>wss?://(?P<host>[\d.]+):(?P<port>\d+))")


class UpProcess(Running):
    """``python -m clients.stack.up_cli --host 127.0.0.1 --port 0 ...`` and what it announced."""

    def __init__(self, *extra_args: str) -> None:
        super().__init__(
            [
                sys.executable,
                "-m",
                "clients.stack.up_cli",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                *extra_args,
            ]
        )

    def wait_ready(self, timeout_s: float = STARTUP_TIMEOUT_S) -> str:
        """Wait for the ``connect to ws://HOST:PORT`` line; the URL."""
        return self.wait_for_line(_CONNECT, timeout_s).group("url")

    def port(self) -> int:
        return int(self.wait_for_line(_CONNECT, 0).group("port"))

    def child_pids(self) -> dict[str, int]:
        """The pid of each component, by title, from the ``[up] started ...`` lines."""
        with self._changed:
            lines = list(self.lines)
        return {
            m.group("title"): int(m.group("pid")) for line in lines if (m := _STARTED.search(line))
        }


def wait_gone(pids: Sequence[int], timeout_s: float = 30.0) -> list[int]:
    """The ``pids`` still alive after waiting up to ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    alive = [pid for pid in pids if pid_alive(pid)]
    while alive and time.monotonic() < deadline:
        time.sleep(0.1)
        alive = [pid for pid in alive if pid_alive(pid)]
    return alive


def kill_leftovers(pids: Sequence[int]) -> None:
    """SIGKILL ``pids`` still alive (cleanup after a failed test; never a broad kill)."""
    for pid in pids:
        if pid_alive(pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                continue
