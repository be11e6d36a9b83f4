"""`up` as a child process for the whole-stack benchmarks (recovery, soak): its output lines
tell the URL to connect to and each component's current pid, which changes on a restart."""

from __future__ import annotations

import asyncio
import re
import signal
import subprocess
import sys
from collections.abc import Callable

from tests.child_process import REPO_ROOT

CONNECT = re.compile(r"connect to (ws://[\d.]+:\d+)")
STARTED = re.compile(r"\[up\]\s+started (\w+) \(pid (\d+)\)")


class Stack:
    """`up --port 0`; `pids` maps `up` and each started component to its current pid."""

    def __init__(self, echo: Callable[[str], bool] = lambda line: False) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "clients.stack.up_cli", "--port", "0"],
            cwd=REPO_ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            bufsize=1,
        )
        self.pids: dict[str, int] = {"up": self.process.pid}
        self.url = ""
        self._echo = echo  # which of up's lines to print (the benchmark's own log)

    async def pump(self, ready: asyncio.Event) -> None:
        """Follow up's output; `ready` is set once the bridge's URL is known."""
        assert self.process.stdout is not None
        while line := await asyncio.to_thread(self.process.stdout.readline):
            if match := STARTED.search(line):
                self.pids[match.group(1)] = int(match.group(2))
            if not self.url and (match := CONNECT.search(line)):
                self.url = match.group(1)
                ready.set()
            if self._echo(line):
                print(line.rstrip(), flush=True)

    def stop(self) -> None:
        self.process.send_signal(signal.SIGINT)
        try:
            self.process.wait(60)
        except subprocess.TimeoutExpired:
            self.process.kill()
