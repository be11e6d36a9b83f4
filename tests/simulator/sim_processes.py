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


def light_config(folder: Path, resolution_deg: float, camera_width_px: int) -> Path:
    """A simulator TOML in `folder` with a coarse scene (no trees or houses), LIDAR at
    `resolution_deg` and a small 4:3 camera: for tests about connections and commands, not
    about the sensors' cost."""
    path = folder / "light_sim.toml"
    path.write_text(
        "[scene]\nterrain_cells = 60\ntrees = 0\nhouses = 0\n"
        f"[lidar]\nhorizontal_resolution_deg = {resolution_deg}\n"
        f"vertical_resolution_deg = {resolution_deg}\n"
        f"[camera]\nwidth_px = {camera_width_px}\nheight_px = {camera_width_px * 3 // 4}\n"
    )
    return path


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
