"""The bridge and the simulator as real child processes, as a user starts them.

A module, not conftest, so the rate, restart and teleop tests and the benchmarks share it
without fixtures leaking into the other simulator tests. The process handling itself is
tests/child_process.py.
"""

from __future__ import annotations

import contextlib
import re
import sys
from collections.abc import Iterator
from pathlib import Path

from tests.child_process import Running, running

_LISTENING = re.compile(r"listening on ws://[^\s:/]+:(?P<port>\d+)")


def bridge_argv(port: int = 0) -> list[str]:
    return [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", str(port)]


def simulator_argv(url: str, config: Path | None = None) -> list[str]:
    argv = [sys.executable, "-m", "simulator", "--bridge", url, "--connect-timeout", "60"]
    return argv + (["--config", str(config)] if config is not None else [])


@contextlib.contextmanager
def running_bridge(port: int = 0) -> Iterator[tuple[Running, str]]:
    """`python -m bridge` on 127.0.0.1:`port` (0: the kernel picks) and its URL."""
    with running(bridge_argv(port)) as child:
        bound = int(child.wait_for_line(_LISTENING).group("port"))
        yield child, f"ws://127.0.0.1:{bound}"


def header_stamp_s(msg: dict) -> float:
    """A simulator message's capture time in seconds (a TFMessage: its first transform's)."""
    header = msg["transforms"][0]["header"] if "transforms" in msg else msg["header"]
    return header["stamp"]["sec"] + header["stamp"]["nanosec"] * 1e-9
