"""Run one roslibjs scenario script (tests/compat/js/*.mjs) under Node and read its result.

Node 20 and the npm install (`npm ci --prefix tests/compat/js`) are requirements of this
suite, not options: when either is missing the test fails with the command that fixes it.
"""

from __future__ import annotations

import asyncio
import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

from .wire import WirePeer

JS_DIR = Path(__file__).resolve().parent / "js"
# The scripts give up by themselves after 60 s (common.mjs HARD_TIMEOUT_MS); this is the
# backstop for a node process that cannot even start.
NODE_TIMEOUT_S = 90.0
# How often a Python publisher repeats while a Node subscriber gets ready (it cannot tell us).
REPUBLISH_PERIOD_S = 0.25
INSTALL_HINT = "install Node >= 20 and run `npm ci --prefix tests/compat/js`"


def node_executable() -> str:
    """Path of `node`, failing the test (not skipping it) when the toolchain is absent."""
    node = shutil.which("node")
    if node is None:
        pytest.fail(f"`node` is not on PATH; the roslibjs tests need it: {INSTALL_HINT}")
    if not (JS_DIR / "node_modules" / "roslib" / "package.json").is_file():
        pytest.fail(f"roslib is not installed in {JS_DIR / 'node_modules'}: {INSTALL_HINT}")
    return node


def run_scenario(script: str, *args: str, timeout_s: float = NODE_TIMEOUT_S) -> dict[str, Any]:
    """Run `node js/<script> args…` and return its JSON result line (which has `ok: true`)."""
    command = [node_executable(), str(JS_DIR / script), *args]
    completed = subprocess.run(
        command, cwd=JS_DIR, capture_output=True, text=True, timeout=timeout_s, check=False
    )
    result_lines = [line for line in completed.stdout.splitlines() if line.startswith("{")]
    context = (
        f"`{' '.join(command)}` exited {completed.returncode}\n"
        f"stdout:\n{completed.stdout[-4000:]}\nstderr:\n{completed.stderr[-4000:]}"
    )
    assert completed.returncode == 0 and result_lines, context
    result = json.loads(result_lines[-1])
    assert result.get("ok") is True, context
    return result


async def publish_while_running(
    peer: WirePeer, topic: str, type_name: str, message: dict[str, Any], script: str, *args: str
) -> dict[str, Any]:
    """Advertise, then publish `message` every REPUBLISH_PERIOD_S until the script reports."""
    await peer.send(
        {"op": "advertise", "id": peer.next_id("advertise"), "topic": topic, "type": type_name}
    )
    await peer.call_service("/rosapi/get_time")
    scenario = asyncio.create_task(asyncio.to_thread(run_scenario, script, *args))
    while not scenario.done():
        await peer.send({"op": "publish", "topic": topic, "msg": message})
        await asyncio.wait({scenario}, timeout=REPUBLISH_PERIOD_S)
    return scenario.result()
