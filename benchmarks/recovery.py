"""Recovery: how long after a kill -9 a component is back and the IMU flows again.

Runs `python -m clients.stack.up_cli --port 0` (bridge, simulator, navigation) and an IMU
client that reconnects on its own (clients.RosbridgeClient, backoff 0.25 s), then kills each
component with SIGKILL in turn, `--rounds` times, waiting between kills until the IMU has
flowed for `--settle` seconds. Per component it prints the medians (and max) of
*respawned* (kill -> up has started the new process) and *IMU back* (kill -> the first IMU
sample stamped after the kill reaches the client), beside the target (IMU back within 5 s,
the issue's bound) and the machine's load. tests/launcher/test_up_stack.py checks that the
stack recovers at all; this is where the time is measured.

Usage: python -m benchmarks.recovery [--rounds 3] [--settle 5]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import statistics
import sys
import time
from pathlib import Path

from benchmarks.up_stack import Stack
from clients import RosbridgeClient
from tests.launcher.sensor_data import imu_flowed, record_imu_arrivals

ROOT = Path(__file__).resolve().parents[1]

TITLES = ("navigation", "simulator", "bridge")
IMU_BACK_TARGET_S = 5.0  # the bound from a kill -9 to IMU flowing again


async def until(condition, timeout_s: float) -> None:  # type: ignore[no-untyped-def]
    """Poll `condition` every 10 ms; TimeoutError after `timeout_s`."""
    async with asyncio.timeout(timeout_s):
        while not condition():
            await asyncio.sleep(0.01)


async def measure(rounds: int, settle_s: float) -> dict[str, list[tuple[float, float]]]:
    """(respawned s, IMU back s) per kill, by component."""
    stack, ready = Stack(), asyncio.Event()
    pump = asyncio.create_task(stack.pump(ready))
    figures: dict[str, list[tuple[float, float]]] = {t: [] for t in TITLES}
    arrivals: list[tuple[float, float]] = []  # (received, stamp), wall-clock seconds
    try:
        await asyncio.wait_for(ready.wait(), 300)
        async with RosbridgeClient(stack.url, encoding="cbor", backoff_max=0.25) as client:
            collector = await record_imu_arrivals(client, arrivals)
            for _ in range(rounds):
                for title in TITLES:
                    flowing_since = time.time()
                    await until(lambda t=flowing_since: imu_flowed(arrivals, t, settle_s), 120)
                    pid, killed = stack.pids[title], time.time()
                    os.kill(pid, signal.SIGKILL)
                    await until(lambda t=title, p=pid: stack.pids[t] != p, 60)
                    respawned = time.time() - killed
                    await until(lambda k=killed: any(s > k for _, s in arrivals[-100:]), 60)
                    back = min(r for r, s in arrivals if s > killed) - killed
                    figures[title].append((respawned, back))
                    print(
                        f"{title}: respawned {respawned:.2f} s, IMU back {back:.2f} s", flush=True
                    )
            collector.cancel()
    finally:
        stack.stop()
        pump.cancel()
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=3, help="kills per component")
    parser.add_argument(
        "--settle", type=float, default=5.0, metavar="S", help="IMU flowing between kills"
    )
    args = parser.parse_args(argv)
    figures = asyncio.run(measure(args.rounds, args.settle))
    load = " / ".join(f"{v:.1f}" for v in os.getloadavg())
    print(f"machine: {os.cpu_count()} CPUs, load average {load} (1/5/15 min)")
    print(
        f"{'component':<11} {'kills':>5} {'respawned p50':>14} {'max':>6} "
        f"{'IMU back p50':>13} {'max':>6}  target"
    )
    for title, pairs in figures.items():
        respawned, back = [p[0] for p in pairs], [p[1] for p in pairs]
        verdict = "met" if statistics.median(back) <= IMU_BACK_TARGET_S else "MISSED"
        print(
            f"{title:<11} {len(pairs):>5} {statistics.median(respawned):>12.2f} s "
            f"{max(respawned):>5.2f} {statistics.median(back):>11.2f} s {max(back):>5.2f}  "
            f"IMU back <= {IMU_BACK_TARGET_S:g} s: {verdict}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
