"""Start the real bridge as a child process (`python -m bridge`) for the compatibility tests.

The third-party clients must talk to exactly what users run, so the bridge is started through
its command line, not imported: `python -m bridge --host 127.0.0.1 --port 0`. The bridge logs a
line containing `listening on ws://HOST:PORT` once its socket is bound; that line is the only
way to learn the port the kernel picked.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]

# A loaded 2-core machine needs several seconds to import numpy, pydantic and rosbags.
STARTUP_TIMEOUT_S = 60.0
# rosbridge-compatible shutdown closes every socket; a few seconds is plenty.
SHUTDOWN_TIMEOUT_S = 15.0

_LISTENING = re.compile(r"listening on wss?://(?P<host>[^\s:/]+):(?P<port>\d+)")


class BridgeStartError(RuntimeError):
    """The bridge process exited or stayed silent instead of announcing its port."""


@dataclass
class BridgeLog:
    """Lines the bridge wrote to stderr, collected by a reader thread (the pipe must drain)."""

    lines: list[str] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def append(self, line: str) -> None:
        with self.lock:
            self.lines.append(line)

    def text(self) -> str:
        with self.lock:
            return "".join(self.lines)


@dataclass(frozen=True)
class BridgeEndpoint:
    """Where a running bridge listens, and what it has logged so far."""

    host: str
    port: int
    log: BridgeLog
    process: subprocess.Popen[str]

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"


def _pump_stderr(stream, log: BridgeLog, found: threading.Event, port_box: list[int]) -> None:
    """Read stderr until EOF, remembering the announced port (runs in a daemon thread)."""
    for line in stream:
        log.append(line)
        match = _LISTENING.search(line)
        if match and not port_box:
            port_box.append(int(match.group("port")))
            found.set()
    found.set()  # EOF: wake the waiter so it can report the exit


def _stop(process: subprocess.Popen[str]) -> int:
    """SIGINT first (the bridge's clean shutdown), SIGKILL if it does not exit in time."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(timeout=SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=SHUTDOWN_TIMEOUT_S)
    return process.returncode


def _bridge_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT), env.get("PYTHONPATH")]))
    env.setdefault("PYTHONUNBUFFERED", "1")
    return env


@contextlib.contextmanager
def running_bridge(extra_args: Sequence[str] = (), port: int = 0) -> Iterator[BridgeEndpoint]:
    """Run `python -m bridge --host 127.0.0.1 --port PORT [extra_args]` for the `with` block.

    PORT 0 lets the kernel pick; a fixed port serves tests that restart the bridge in place.

    Raises BridgeStartError, quoting the process output, if no `listening on` line appears
    within STARTUP_TIMEOUT_S or the process exits first.
    """
    command = [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", str(port)]
    command.extend(extra_args)
    process = subprocess.Popen(
        command,
        cwd=REPO_ROOT,
        env=_bridge_env(),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        encoding="utf-8",
        errors="replace",
    )
    log, found, port_box = BridgeLog(), threading.Event(), []
    reader = threading.Thread(
        target=_pump_stderr, args=(process.stderr, log, found, port_box), daemon=True
    )
    reader.start()
    try:
        found.wait(STARTUP_TIMEOUT_S)
        if not port_box:
            code = _stop(process)
            reader.join(timeout=5.0)
            raise BridgeStartError(
                f"`{' '.join(command)}` did not log 'listening on ws://HOST:PORT' within "
                f"{STARTUP_TIMEOUT_S:.0f} s (exit code {code}). Its output:\n{log.text()}"
            )
        yield BridgeEndpoint("127.0.0.1", port_box[0], log, process)
    finally:
        _stop(process)
        reader.join(timeout=5.0)
        if not reader.is_alive():  # (a reader still blocked in it would fail on a closed pipe)
            process.stderr.close()


def free_port() -> int:
    """A loopback port nobody listens on right now (for a bridge restarted on the same port)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def stop_bridge(endpoint: BridgeEndpoint) -> int:
    """Stop the bridge now (SIGINT, then kill) and return its exit code."""
    return _stop(endpoint.process)
