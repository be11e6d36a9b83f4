"""Run the bridge and the simulator as real child processes, as a user starts them.

A module, not conftest, so the rate, restart and teleop tests share it without fixtures
leaking into the other simulator tests. A reader thread drains each child's merged output (a
full pipe would stall the child) and keeps the lines, so a test can wait for a line and quote
the whole output when it fails.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
# Importing numpy, pydantic, rosbags and Embree, and building the scene, on a loaded 2-core box.
STARTUP_TIMEOUT_S = 90.0
STOP_TIMEOUT_S = 20.0
_LISTENING = re.compile(r"listening on ws://[^\s:/]+:(?P<port>\d+)")


class Child:
    """One child process with its stdout and stderr collected line by line."""

    def __init__(self, argv: Sequence[str]) -> None:
        self.argv = list(argv)
        self.lines: list[str] = []
        self._changed = threading.Condition()
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT),
                                                          env.get("PYTHONPATH")]))
        env["PYTHONUNBUFFERED"] = "1"
        self.process = subprocess.Popen(
            self.argv, cwd=REPO_ROOT, env=env, stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, encoding="utf-8",
            errors="replace")
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            with self._changed:
                self.lines.append(line.rstrip("\n"))
                self._changed.notify_all()
        with self._changed:
            self._changed.notify_all()

    def text(self) -> str:
        with self._changed:
            return "\n".join(self.lines)

    def wait_for(self, pattern: re.Pattern[str], timeout_s: float = STARTUP_TIMEOUT_S,
                 after: int = 0) -> re.Match[str]:
        """The first match of `pattern` in a line from index `after` on; AssertionError (with
        the output) if the process exits or `timeout_s` passes first."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                for line in self.lines[after:]:
                    if match := pattern.search(line):
                        return match
                remaining = deadline - time.monotonic()
                if remaining <= 0 or (self.process.poll() is not None
                                      and not self._reader.is_alive()):
                    raise AssertionError(f"{' '.join(self.argv)} never logged "
                                         f"{pattern.pattern!r}; output:\n{self.text()}")
                self._changed.wait(min(remaining, 0.5))

    def stop(self) -> int:
        """SIGINT (the clean shutdown of every riverbridge process), then SIGKILL."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout=STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=STOP_TIMEOUT_S)
        self._reader.join(timeout=5.0)
        return self.process.returncode


@contextlib.contextmanager
def running(argv: Sequence[str]) -> Iterator[Child]:
    """`argv` as a child process for the `with` block, stopped on the way out."""
    child = Child(argv)
    try:
        yield child
    finally:
        child.stop()


def bridge_argv(port: int = 0) -> list[str]:
    return [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", str(port)]


def simulator_argv(url: str, config: Path | None = None) -> list[str]:
    argv = [sys.executable, "-m", "simulator", "--bridge", url, "--connect-timeout", "60"]
    return argv + (["--config", str(config)] if config is not None else [])


@contextlib.contextmanager
def running_bridge(port: int = 0) -> Iterator[tuple[Child, str]]:
    """`python -m bridge` on 127.0.0.1:`port` (0: the kernel picks) and its URL."""
    with running(bridge_argv(port)) as child:
        bound = int(child.wait_for(_LISTENING).group("port"))
        yield child, f"ws://127.0.0.1:{bound}"


def header_stamp_s(msg: dict) -> float:
    """A simulator message's capture time in seconds (a TFMessage: its first transform's)."""
    header = msg["transforms"][0]["header"] if "transforms" in msg else msg["header"]
    return header["stamp"]["sec"] + header["stamp"]["nanosec"] * 1e-9
