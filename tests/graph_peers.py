"""Independent participants of the external graphs (plain cyclonedds, plain eclipse-zenoh
scripts under tests/dds and tests/zenoh) as child processes, and what the DDS and Zenoh tests
around them share.

A peer script imports no riverbridge code, so it runs with a minimal environment of its own
(`env`); it prints one JSON line with what it saw (`run_json_peer`), or "READY" once it serves
and then keeps serving until it is stopped (`serving_peer`).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import subprocess
import sys
from collections.abc import AsyncIterator, Mapping
from pathlib import Path
from typing import Any

from bridge.dds.cyclone_xml import CycloneSettings, cyclone_xml
from clients.subscription import Subscription
from simulator.config import CameraConfig, LidarConfig, SceneConfig, SimConfig
from simulator.node import serve
from simulator.scene import build_scene
from tests.receiving import surge_speed_reaches

PEER_TIMEOUT_S = 90.0  # a peer's whole run, discovery on a loaded 2-core machine included
# Coarse terrain and a sparse LIDAR keep the simulator light on two shared cores.
LIGHT_SIM = SimConfig(
    scene=SceneConfig(terrain_cells=80, trees=10, houses=3),
    lidar=LidarConfig(horizontal_resolution_deg=2.0, vertical_resolution_deg=2.0, rate_hz=4.0),
    camera=CameraConfig(width_px=160, height_px=120, rate_hz=4.0),
)


def cyclone_loopback_env() -> dict[str, str]:
    """The environment of a plain-cyclonedds peer: DDS on the loopback only."""
    return {"CYCLONEDDS_URI": cyclone_xml(CycloneSettings(), tuned=False), "PATH": "/usr/bin"}


async def run_json_peer(
    script: Path, *args: str, env: Mapping[str, str], timeout_s: float = PEER_TIMEOUT_S
) -> Any:
    """Run `script ARGS...` in its own process to its end; its last JSON line. A peer that
    fails, or prints none, fails the test with its output."""
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        str(script),
        *args,
        env=dict(env),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        async with asyncio.timeout(timeout_s):
            out, err = await process.communicate()
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()
    lines = [line for line in out.decode().splitlines() if line.startswith("{")]
    assert process.returncode == 0 and lines, (out.decode(), err.decode()[-3000:])
    return json.loads(lines[-1])


def _start_ready(
    script: Path, args: tuple[str, ...], env: Mapping[str, str]
) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, str(script), *args],
        env=dict(env),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert process.stdout is not None
    line = process.stdout.readline()
    assert line.startswith("READY"), line + process.stdout.read()
    return process


@contextlib.asynccontextmanager
async def serving_peer(
    script: Path, *args: str, env: Mapping[str, str]
) -> AsyncIterator[subprocess.Popen[str]]:
    """`script ARGS...` started and serving (it said "READY") for the block; killed after."""
    process = await asyncio.to_thread(_start_ready, script, args, env)
    try:
        yield process
    finally:
        process.kill()
        process.communicate()


class RecordingService:
    """A websocket client's service handler that keeps each request and gives `answer`."""

    def __init__(self, answer: dict[str, Any]) -> None:
        self.answer = answer
        self.requests: list[dict[str, Any]] = []

    async def __call__(self, args: dict[str, Any]) -> dict[str, Any]:
        self.requests.append(args)
        return self.answer


@contextlib.asynccontextmanager
async def light_simulator(url: str) -> AsyncIterator[None]:
    """The simulator (`LIGHT_SIM`) publishing its sensors to the bridge at `url` and taking
    its commands for the block; stopped after."""
    scene = await asyncio.to_thread(build_scene, LIGHT_SIM.scene, seed=LIGHT_SIM.seed)
    stop = asyncio.Event()
    sim = asyncio.create_task(serve(url, LIGHT_SIM, stop, scene=scene))
    try:
        yield
    finally:
        stop.set()
        await sim


async def speed_while_steering(
    steering: asyncio.Task[Any], odom: Subscription, target_mps: float, timeout_s: float
) -> float:
    """The vessel's surge speed once it reaches `target_mps` while a peer steers it
    (`steering`, its run); a peer that ends first has failed, and fails the test with its
    output."""
    moving = asyncio.create_task(surge_speed_reaches(odom, target_mps, timeout_s=timeout_s))
    await asyncio.wait({moving, steering}, return_when=asyncio.FIRST_COMPLETED)
    if steering.done():
        steering.result()
    return await moving
