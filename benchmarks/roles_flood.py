"""Fairness under a flood: one principal floods at its quota, another's IMU keeps its pace.

Runs `python -m bridge --roles FILE --auth-secret-file FILE` as its own process. A "sensor"
principal publishes a small `sensor_msgs/Imu` at 200 Hz and subscribes to it on a second
connection (latency = decoded time - `header.stamp`, one wall clock); a "flooder" principal
in another process publishes ~100-byte messages as fast as its socket takes them. Phases
alternate quiet / flood (the flooder paused or sending) so load changes on this shared
machine hit both conditions alike; the figure is the ratio of the IMU's p99 with the flood
to its p99 without. With `--no-quota` the flooder's role has no limits: what the quota (and
the bridge holding a flooder's reads until its quota has room) buys.

Usage: python -m benchmarks.roles_flood [--phase-s 4] [--phases 6] [--no-quota]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.request
from dataclasses import dataclass
from multiprocessing.synchronize import Event
from pathlib import Path

import numpy as np
import websockets

from schemas import tokens

SECRET = "benchmark-secret-0123456789abcdef0123"
IMU_PERIOD_S = 0.005  # 200 Hz
FLOOD_QUOTA = "messages_per_s = 200\nbytes_per_s = 100_000\n"
ROLES = """
[roles.sensor]
subscribe = ["*"]
publish = ["/imu"]
call_service = ["/rosapi/*"]

[roles.flooder]
publish = ["/flood"]
call_service = ["/rosapi/*"]

[roles.flooder.limits]
"""


@dataclass
class FloodResult:
    """IMU latencies (ms) per condition, and what the flooder got through."""

    quiet_ms: list[float]
    flood_ms: list[float]
    flood_sent: int
    flood_accepted: int
    flood_dropped: int

    def p99(self, condition: str) -> float:
        return float(np.percentile(getattr(self, f"{condition}_ms"), 99))

    def p50(self, condition: str) -> float:
        return float(np.percentile(getattr(self, f"{condition}_ms"), 50))

    @property
    def ratio(self) -> float:
        return self.p99("flood") / self.p99("quiet")


def start_bridge(folder: Path, quota: bool) -> tuple[subprocess.Popen[str], str]:
    (folder / "secret").write_text(SECRET + "\n")
    (folder / "roles.toml").write_text(ROLES + (FLOOD_QUOTA if quota else ""))
    command = [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "warning"]
    command += ["--roles", str(folder / "roles.toml"), "--auth-secret-file", str(folder / "secret")]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    assert process.stderr is not None
    for line in process.stderr:
        match = re.search(r"listening on (ws://\S+)", line)
        if match:
            return process, match.group(1)
    raise RuntimeError("the bridge exited before listening")


def bearer(role: str, subject: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {tokens.issue(SECRET, role, subject, time.time(), 3600)}"}


def flood(url: str, flooding: Event, stop: Event, sent: multiprocessing.Value) -> None:  # type: ignore[valid-type]
    """The flooder process: publish as fast as the socket takes it while `flooding` is set."""

    async def run() -> None:
        async with websockets.connect(url, additional_headers=bearer("flooder", "flooder")) as ws:
            await ws.send(
                json.dumps({"op": "advertise", "topic": "/flood", "type": "std_msgs/String"})
            )
            frame = json.dumps({"op": "publish", "topic": "/flood", "msg": {"data": "x" * 60}})
            count = 0
            while not stop.is_set():
                if not flooding.is_set():
                    await asyncio.sleep(0.01)
                    continue
                for _ in range(100):
                    await ws.send(frame)
                count += 100
                sent.value = count  # type: ignore[attr-defined]

    asyncio.run(run())


async def imu_phase(
    pub: websockets.ClientConnection, sub: websockets.ClientConnection, seconds: float
) -> list[float]:
    """IMU latencies in ms for one phase."""
    latencies: list[float] = []
    end = time.monotonic() + seconds

    async def read() -> None:
        while True:
            message = json.loads(await sub.recv())
            stamp = message["msg"]["header"]["stamp"]
            latencies.append((time.time_ns() - stamp["sec"] * 10**9 - stamp["nanosec"]) / 1e6)

    reader = asyncio.create_task(read())
    while time.monotonic() < end:
        now = time.time_ns()
        header = {"stamp": {"sec": now // 10**9, "nanosec": now % 10**9}, "frame_id": "imu"}
        await pub.send(json.dumps({"op": "publish", "topic": "/imu", "msg": {"header": header}}))
        await asyncio.sleep(IMU_PERIOD_S)
    await asyncio.sleep(0.2)
    reader.cancel()
    return latencies


def principal_counter(http_url: str, counter: str, principal: str) -> int:
    with urllib.request.urlopen(f"{http_url}/metrics", timeout=20) as page:
        text = page.read().decode()
    found = re.search(
        rf'riverbridge_principal_{counter}_total{{principal="{principal}"}} (\S+)', text
    )
    return int(float(found.group(1))) if found else 0


async def measure(
    url: str, phase_s: float, phases: int, flooding: Event, sent: object
) -> FloodResult:
    result = FloodResult([], [], 0, 0, 0)
    async with (
        websockets.connect(url, additional_headers=bearer("sensor", "imu")) as pub,
        websockets.connect(url, additional_headers=bearer("sensor", "viewer")) as sub,
    ):
        await pub.send(json.dumps({"op": "advertise", "topic": "/imu", "type": "sensor_msgs/Imu"}))
        await sub.send(json.dumps({"op": "subscribe", "topic": "/imu", "type": "sensor_msgs/Imu"}))
        await imu_phase(pub, sub, 1.0)  # warm-up
        for phase in range(phases):
            condition = "flood" if phase % 2 else "quiet"
            if condition == "flood":
                flooding.set()
                await asyncio.sleep(0.5)  # the flood is under way before measuring
            samples = await imu_phase(pub, sub, phase_s)
            flooding.clear()
            getattr(result, f"{condition}_ms").extend(samples)
    result.flood_sent = sent.value  # type: ignore[attr-defined]
    http_url = url.replace("ws://", "http://")
    result.flood_accepted = principal_counter(http_url, "messages", "flooder")
    result.flood_dropped = principal_counter(http_url, "dropped", "flooder")
    return result


def run(phase_s: float, phases: int, quota: bool) -> FloodResult:
    """One bridge, one flooder process, `phases` alternating phases (quiet first)."""
    context = multiprocessing.get_context("spawn")
    flooding, stop = context.Event(), context.Event()
    sent = context.Value("q", 0)
    with tempfile.TemporaryDirectory() as folder:
        bridge, url = start_bridge(Path(folder), quota)
        flooder = context.Process(target=flood, args=(url, flooding, stop, sent), daemon=True)
        flooder.start()
        try:
            return asyncio.run(measure(url, phase_s, phases, flooding, sent))
        finally:
            stop.set()
            flooder.join(10)
            if flooder.is_alive():
                flooder.kill()
            bridge.terminate()
            bridge.wait(10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phase-s", type=float, default=4.0)
    parser.add_argument("--phases", type=int, default=6)
    parser.add_argument("--no-quota", action="store_true")
    args = parser.parse_args(argv)
    print(f"load {os.getloadavg()[0]:.2f}; quota {'off' if args.no_quota else 'on'}")
    result = run(args.phase_s, args.phases, not args.no_quota)
    for condition in ("quiet", "flood"):
        samples = getattr(result, f"{condition}_ms")
        print(
            f"IMU {condition:5s} n={len(samples):5d}  p50 {result.p50(condition):6.2f} ms  "
            f"p99 {result.p99(condition):6.2f} ms"
        )
    print(f"p99 flood / quiet: {result.ratio:.2f}")
    print(
        f"flooder: sent {result.flood_sent}, accepted {result.flood_accepted}, "
        f"dropped {result.flood_dropped}; load {os.getloadavg()[0]:.2f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
