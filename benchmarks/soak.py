"""Soak: the whole stack for N minutes with a slow and a vanishing client; memory must stay flat.

Runs `python -m clients.stack.up_cli --port 0` (bridge, simulator, navigation) and beside it:

- an IMU probe: subscribes to /imu/data and records capture -> received per sample;
- a slow client: subscribes to the LIDAR scan, the camera and the IMU (CBOR) and reads one
  frame a second, so the bridge keeps dropping its oldest messages;
- a vanishing client: every few seconds connects, subscribes, advertises a service, calls
  rosapi, and drops its TCP connection without a closing handshake.

Every minute it samples the resident memory of `up` and of each component (by its current
pid: a restarted component is followed) and the IMU latency p50/p99 of that minute; at the end
it prints the table, the RSS growth of each process after the first two minutes (slope by least
squares, MiB per minute) and writes soak.csv and soak.png (matplotlib) to --output.

Usage: python -m benchmarks.soak [--minutes 30] [--output artifacts/soak]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import csv
import json
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import websockets
from websockets.exceptions import ConnectionClosed

from benchmarks.up_stack import Stack
from tests.child_process import REPO_ROOT as ROOT

PAGE_KIB = 4  # /proc/PID/statm counts pages
WARM_UP_MINUTES = 2  # imports, caches and buffers settle in the first minutes


@dataclass
class Samples:
    rss_mib: dict[str, list[float]] = field(default_factory=dict)  # process -> per minute
    imu_p50_ms: list[float] = field(default_factory=list)
    imu_p99_ms: list[float] = field(default_factory=list)
    imu_count: list[int] = field(default_factory=list)
    vanished: int = 0
    slow_frames: int = 0


def rss_mib(pid: int) -> float:
    try:
        pages = int(Path(f"/proc/{pid}/statm").read_text().split()[1])
    except (FileNotFoundError, ProcessLookupError, IndexError, ValueError):
        return float("nan")
    return pages * PAGE_KIB / 1024


def _restart_or_error(line: str) -> bool:
    """up's lines worth seeing in the soak's log: restarts and errors."""
    return "restarting it" in line or " ERROR " in line


def subscribe(topic: str, type_name: str, compression: str = "cbor") -> str:
    return json.dumps(
        {"op": "subscribe", "topic": topic, "type": type_name, "compression": compression}
    )


async def imu_probe(url: str, latencies_ms: list[float], stop: asyncio.Event) -> None:
    while not stop.is_set():
        with contextlib.suppress(OSError, ConnectionClosed):
            async with websockets.connect(url, max_size=None) as ws:
                await ws.send(subscribe("/imu/data", "sensor_msgs/msg/Imu", "none"))
                while not stop.is_set():
                    frame = await ws.recv()
                    stamp = json.loads(frame)["msg"]["header"]["stamp"]
                    latencies_ms.append(
                        time.time() * 1e3 - stamp["sec"] * 1e3 - stamp["nanosec"] / 1e6
                    )
        await asyncio.sleep(0.5)


async def slow_client(url: str, samples: Samples, stop: asyncio.Event) -> None:
    while not stop.is_set():
        with contextlib.suppress(OSError, ConnectionClosed):
            async with websockets.connect(url, max_size=None, max_queue=1) as ws:
                for topic, type_name in (
                    ("/lidar/points", "sensor_msgs/msg/PointCloud2"),
                    ("/camera/image/compressed", "sensor_msgs/msg/CompressedImage"),
                    ("/imu/data", "sensor_msgs/msg/Imu"),
                ):
                    await ws.send(subscribe(topic, type_name))
                while not stop.is_set():
                    await ws.recv()
                    samples.slow_frames += 1
                    await asyncio.sleep(1.0)
        await asyncio.sleep(0.5)


async def vanishing_client(
    url: str, period_s: float, samples: Samples, stop: asyncio.Event
) -> None:
    while not stop.is_set():
        with contextlib.suppress(OSError, ConnectionClosed):
            ws = await websockets.connect(url, max_size=None)
            await ws.send(subscribe("/lidar/points", "sensor_msgs/msg/PointCloud2"))
            await ws.send(subscribe("/odom", "nav_msgs/msg/Odometry", "none"))
            await ws.send(
                json.dumps(
                    {
                        "op": "advertise_service",
                        "service": "/vanishing",
                        "type": "std_srvs/srv/Trigger",
                    }
                )
            )
            await ws.send(
                json.dumps(
                    {"op": "call_service", "id": 1, "service": "/rosapi/topics_and_raw_types"}
                )
            )
            await asyncio.sleep(min(1.0, period_s / 2))
            ws.transport.abort()  # gone without a closing handshake
            samples.vanished += 1
        await asyncio.sleep(period_s)


def sample_minute(stack: Stack, samples: Samples, latencies_ms: list[float]) -> None:
    for name, pid in stack.pids.items():
        samples.rss_mib.setdefault(name, []).append(rss_mib(pid))
    window, latencies_ms[:] = sorted(latencies_ms), []
    samples.imu_count.append(len(window))
    samples.imu_p50_ms.append(statistics.median(window) if window else float("nan"))
    samples.imu_p99_ms.append(window[int(0.99 * (len(window) - 1))] if window else float("nan"))
    minute = len(samples.imu_count)
    rss = ", ".join(f"{n} {v[-1]:.0f}" for n, v in samples.rss_mib.items())
    print(
        f"minute {minute}: IMU n={len(window)} p50 {samples.imu_p50_ms[-1]:.1f} "
        f"p99 {samples.imu_p99_ms[-1]:.1f} ms; RSS MiB: {rss}",
        flush=True,
    )


async def soak(minutes: int, vanishing_period_s: float) -> Samples:
    stack, samples = Stack(echo=_restart_or_error), Samples()
    ready, stop = asyncio.Event(), asyncio.Event()
    pump = asyncio.create_task(stack.pump(ready))
    try:
        await asyncio.wait_for(ready.wait(), 300)
        latencies_ms: list[float] = []
        clients = [
            asyncio.create_task(imu_probe(stack.url, latencies_ms, stop)),
            asyncio.create_task(slow_client(stack.url, samples, stop)),
            asyncio.create_task(vanishing_client(stack.url, vanishing_period_s, samples, stop)),
        ]
        for _ in range(minutes):
            await asyncio.sleep(60)
            sample_minute(stack, samples, latencies_ms)
        stop.set()
        for task in clients:
            task.cancel()
        await asyncio.gather(*clients, return_exceptions=True)
    finally:
        stack.stop()
        await pump
    return samples


def growth_mib_per_min(series: list[float]) -> float:
    """Least-squares slope after the warm-up minutes (NaN when too short)."""
    tail = np.array(series[WARM_UP_MINUTES:], dtype=float)
    tail = tail[np.isfinite(tail)]
    if len(tail) < 2:
        return float("nan")
    return float(np.polyfit(np.arange(len(tail)), tail, 1)[0])


def write_outputs(samples: Samples, output: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    output.mkdir(parents=True, exist_ok=True)
    minutes = list(range(1, len(samples.imu_count) + 1))
    with (output / "soak.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        names = list(samples.rss_mib)
        writer.writerow(
            ["minute", *(f"rss_mib_{n}" for n in names), "imu_n", "imu_p50_ms", "imu_p99_ms"]
        )
        for i, minute in enumerate(minutes):
            writer.writerow(
                [
                    minute,
                    *(f"{samples.rss_mib[n][i]:.1f}" for n in names),
                    samples.imu_count[i],
                    f"{samples.imu_p50_ms[i]:.2f}",
                    f"{samples.imu_p99_ms[i]:.2f}",
                ]
            )
    figure, (memory, latency) = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    for name, series in samples.rss_mib.items():
        memory.plot(minutes, series, marker="o", label=name)
    memory.set_ylabel("RSS (MiB)")
    memory.legend()
    memory.grid(alpha=0.3)
    latency.plot(minutes, samples.imu_p99_ms, marker="o", label="p99")
    latency.plot(minutes, samples.imu_p50_ms, marker=".", label="p50")
    latency.set_ylabel("IMU capture -> client (ms)")
    latency.set_xlabel("minute")
    latency.legend()
    latency.grid(alpha=0.3)
    figure.suptitle("riverbridge soak: full stack, a slow and a vanishing client")
    figure.tight_layout()
    figure.savefig(output / "soak.png", dpi=100)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=int, default=30)
    parser.add_argument("--vanishing-period", type=float, default=5.0, metavar="S")
    parser.add_argument("--output", type=Path, default=ROOT / "artifacts" / "soak")
    args = parser.parse_args(argv)
    samples = asyncio.run(soak(args.minutes, args.vanishing_period))
    write_outputs(samples, args.output)
    print(
        f"vanishing connections: {samples.vanished}; frames the slow client read: "
        f"{samples.slow_frames}"
    )
    for name, series in samples.rss_mib.items():
        print(
            f"RSS {name}: first {series[0]:.0f} MiB, last {series[-1]:.0f} MiB, after "
            f"minute {WARM_UP_MINUTES}: {growth_mib_per_min(series):+.2f} MiB/min"
        )
    print(f"IMU p99 per minute (ms): {[round(v, 1) for v in samples.imu_p99_ms]}")
    print(f"wrote {args.output / 'soak.csv'} and {args.output / 'soak.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
