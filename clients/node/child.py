"""One component of the stack as a child process: how it is started, read, signalled and reaped.

Each runs as ``sys.executable -m <package> ...`` in its own process group, with Linux's
parent-death signal set, its stdout and stderr one pipe pumped line by line into the
supervisor's :class:`~clients.node.output.PrefixedOutput` (see :mod:`clients.stack.launcher`).
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import ctypes.util
import logging
import os
import re
import signal
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from clients.node.output import PrefixedOutput

log = logging.getLogger("clients.stack.launcher")  # one logger for the supervisor's lines

BRIDGE_URL = "{bridge_url}"
"""Placeholder in a component's arguments, replaced by the bridge's URL once it listens."""

_LISTENING = re.compile(rb"listening on wss?://(?P<host>\S+?):(?P<port>\d+)")
_EXIT_POLL_S = 0.05  # how often a child's exit is looked for (see Child.wait)
_LINE_LIMIT = 1 << 20  # longest log line read in one piece; longer ones are split


@dataclass(frozen=True)
class Component:
    """One child process: ``python -m module *args``; ready when ``topics`` have publishers
    (for the bridge, which has none: when it listens and answers ``/version``)."""

    name: str
    title: str
    module: str
    args: tuple[str, ...]
    topics: tuple[str, ...] = ()

    def argv(self, bridge_url: str = "") -> list[str]:
        return [
            sys.executable,
            "-m",
            self.module,
            *(arg.replace(BRIDGE_URL, bridge_url) for arg in self.args),
        ]


def describe_exit(title: str, code: int) -> str:
    """``"simulator exited with code 3"`` or ``"... was killed by SIGKILL (exit code -9)"``."""
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"{title} was killed by {signal.Signals(-code).name} (exit code {code})"
    return f"{title} exited with code {code}"


def _parent_death_signal() -> Callable[[], None] | None:
    """A ``preexec_fn`` asking Linux to SIGTERM the child when its parent dies, or None where
    ``prctl`` is unavailable. libc is resolved here, before fork, so the child only calls it."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    pr_set_pdeathsig = 1
    parent_pid = os.getpid()

    def preexec() -> None:
        prctl(pr_set_pdeathsig, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() != parent_pid:  # the parent died before prctl took effect
            os.kill(os.getpid(), signal.SIGTERM)

    return preexec


@dataclass
class Child:
    """A running component: its process, its log pump and (bridge) the announced port."""

    component: Component
    process: asyncio.subprocess.Process
    output: PrefixedOutput
    port: asyncio.Future[int] = field(
        default_factory=lambda: asyncio.get_running_loop().create_future()
    )
    started_s: float = field(default_factory=time.monotonic)
    # Serving (the bridge answers /version; a client's topics have publishers): from then on
    # the child handles SIGINT itself, so dying of it is a failure, not a stop while starting.
    ready: bool = False
    _pump: asyncio.Task[None] | None = None

    @classmethod
    async def start(
        cls, component: Component, bridge_url: str, env: Mapping[str, str], output: PrefixedOutput
    ) -> Child:
        process = await asyncio.create_subprocess_exec(
            *component.argv(bridge_url),
            stdin=asyncio.subprocess.DEVNULL,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
            env=dict(env),
            process_group=0,
            preexec_fn=_parent_death_signal(),
            limit=_LINE_LIMIT,
        )
        child = cls(component, process, output)
        child._pump = asyncio.create_task(child._pump_lines(), name=f"{component.name} log")
        log.info("started %s (pid %d)", component.title, process.pid)
        return child

    @property
    def pid(self) -> int:
        return self.process.pid

    async def _pump_lines(self) -> None:
        stream = self.process.stdout
        assert stream is not None
        while True:
            try:
                line = await stream.readline()
            except ValueError:  # asyncio discards a line over _LINE_LIMIT; say so
                line = b"[a log line longer than %d bytes was dropped]" % _LINE_LIMIT
            if not line:
                break
            if not self.port.done() and (match := _LISTENING.search(line)):
                self.port.set_result(int(match.group("port")))
            self.output.write(self.component.name, line.decode("utf-8", "replace").rstrip())

    async def wait(self) -> int:
        """Wait for the exit and for the last log line to be written; the exit code.

        What the child left in its process group (navigation's LIDAR worker pool, after a
        kill -9) is killed at once: it holds the output pipe, and its memory, for seconds
        after the child is gone. ``Process.wait()`` (Python 3.11) waits for that pipe too, so
        the exit is taken from ``returncode``, which is set the moment the child is reaped.
        """
        while self.process.returncode is None:
            await asyncio.sleep(_EXIT_POLL_S)
        code = self.process.returncode
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.pid, signal.SIGKILL)
        await self.process.wait()
        if self._pump is not None:
            await asyncio.shield(self._pump)  # a cancelled waiter must not stop the pump
        return code

    def signal_group(self, sig: signal.Signals) -> None:
        """Send ``sig`` to the child's process group (the child and anything it started)."""
        if self.process.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.pid, sig)

    async def stop(self, timeout_s: float) -> int:
        """SIGINT, then SIGTERM, then SIGKILL, ``timeout_s`` apart; the exit code."""
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
            self.signal_group(sig)
            try:
                return await asyncio.wait_for(asyncio.shield(self.wait()), timeout_s)
            except TimeoutError:
                log.warning(
                    "%s did not exit within %.0f s of %s", self.component.title, timeout_s, sig.name
                )
        return await self.wait()
