"""Real child processes for the integration tests and benchmarks, and what they leave behind.

Components are started as a user or docker starts them: as separate processes, through their
command lines. A reader thread drains each process's merged output (a full pipe would stall
the child) and keeps the lines, so a test can wait for a line and quote the whole output when
it fails.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import threading
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]

# Importing numpy, pydantic, rosbags, Embree and building the scene on a loaded 2-core machine.
STARTUP_TIMEOUT_S = 180.0
STOP_TIMEOUT_S = 60.0


def repo_env(extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """The test's environment with the checkout importable, plus ``extra``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO_ROOT), env.get("PYTHONPATH")]))
    env["PYTHONUNBUFFERED"] = "1"  # log lines arrive as they are written
    env.update(extra or {})
    return env


def run_command(
    argv: Sequence[str], timeout_s: float = 120.0, cwd: Path = REPO_ROOT
) -> subprocess.CompletedProcess[str]:
    """Run a command line to its end as a user would (from the checkout, with its environment),
    its output kept as text for the test's assertions."""
    return subprocess.run(
        list(argv), cwd=cwd, env=repo_env(), capture_output=True, text=True, timeout=timeout_s
    )


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def pid_alive(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
    return state != "Z"


class Running:
    """One child process with its output collected line by line."""

    def __init__(
        self, argv: Sequence[str], env: Mapping[str, str] | None = None, cwd: Path = REPO_ROOT
    ) -> None:
        self.argv = list(argv)
        self.lines: list[str] = []
        self._changed = threading.Condition()
        self.process = subprocess.Popen(
            self.argv,
            cwd=cwd,
            env=dict(env or repo_env()),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            encoding="utf-8",
            errors="replace",
            start_new_session=True,
        )
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

    def wait_for_line(
        self, pattern: re.Pattern[str] | str, timeout_s: float = STARTUP_TIMEOUT_S, after: int = 0
    ) -> re.Match[str]:
        """The first output line from index ``after`` on matching ``pattern``; AssertionError
        quoting the output if the process exits or ``timeout_s`` passes first."""
        regex = re.compile(pattern)
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                for line in self.lines[after:]:
                    if match := regex.search(line):
                        return match
                remaining = deadline - time.monotonic()
                exited = self.process.poll() is not None and not self._reader.is_alive()
                if remaining <= 0 or exited:
                    raise AssertionError(
                        f"no line matching {regex.pattern!r} from `{' '.join(self.argv)}` "
                        f"(exit code {self.process.poll()}); its output:\n{self.text()}"
                    )
                self._changed.wait(min(remaining, 1.0))

    def stop(self, sig: signal.Signals = signal.SIGINT, timeout_s: float = STOP_TIMEOUT_S) -> int:
        """Send ``sig`` (if still running) and wait; kill the whole session if it hangs."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
        try:
            code = self.process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=timeout_s)
            raise AssertionError(
                f"`{' '.join(self.argv)}` ignored {sig.name} for {timeout_s} s;"
                f" output:\n{self.text()}"
            ) from None
        self._reader.join(timeout=10.0)
        self._close_output()
        return code

    def _close_output(self) -> None:
        """Close our end of the output pipe once the reader has seen its end."""
        if not self._reader.is_alive() and self.process.stdout is not None:
            self.process.stdout.close()

    def kill_session(self) -> None:
        """Last-resort cleanup: SIGKILL everything in the process's session."""
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=STOP_TIMEOUT_S)
        self._reader.join(timeout=10.0)
        self._close_output()


@contextlib.contextmanager
def running(argv: Sequence[str]) -> Iterator[Running]:
    """``argv`` as a child process for the ``with`` block; on the way out SIGINT (the clean
    shutdown of every riverbridge process), and SIGKILL of its session should it hang."""
    child = Running(argv)
    try:
        yield child
    finally:
        try:
            child.stop()
        finally:
            child.kill_session()
