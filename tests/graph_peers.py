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

PEER_TIMEOUT_S = 90.0  # a peer's whole run, discovery on a loaded 2-core machine included


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
