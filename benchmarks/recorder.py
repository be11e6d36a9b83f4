"""Does `riverbridge record` keep up? Messages/s and MB/s it writes, against what the bridge got.

Two cases, each measured over a window while the recorder process runs:

1. ``stack``: `riverbridge up` (simulator LIDAR, radar, camera, IMU at their configured rates,
   navigation outputs, telemetry), every topic recorded;
2. ``scans``: a bare bridge and a publisher of thesis-sized LIDAR scans (345,600 points x 16 B
   = 5.5 MB, Table 4.3) at ``--scan-hz`` (default 2, 5 and 10 Hz) beside a 100 Hz IMU.

For each it prints, per topic, the messages the bridge received in the window
(/riverbridge/stats) and those in the file whose publish_time (the bridge's entry time) lies in
the window, the recorder's messages/s, MB/s (CDR) and CPU, the file size (zstd) and the
machine's load. ``--burn N`` runs N busy-looping processes meanwhile (a loaded machine).

Usage: python -m benchmarks.recorder [--window S] [--case stack|scans|all] [--scan-hz 2 5 10]
       [--burn N] [--compression zstd|lz4|none]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import multiprocessing
import os
import re
import signal
import sys
import tempfile
import time
from collections import Counter
from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

from clients import RosbridgeClient
from schemas.message import ns_to_stamp
from schemas.tracing import STATS_SERVICE, STATS_SERVICE_TYPE

SCAN_POINTS = 345_600  # Table 4.3: 1440 x 240 beams, x, y, z, intensity float32
NS_PER_S = 1_000_000_000
CLK_TCK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


async def start(*argv: str) -> asyncio.subprocess.Process:
    return await asyncio.create_subprocess_exec(
        *argv,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


async def wait_line(
    process: asyncio.subprocess.Process, pattern: str, timeout_s: float = 300
) -> re.Match[bytes]:
    assert process.stdout is not None
    async with asyncio.timeout(timeout_s):
        while line := await process.stdout.readline():
            if match := re.search(pattern.encode(), line):
                return match
    raise RuntimeError(f"process ended before {pattern!r}")


async def drain(process: asyncio.subprocess.Process) -> None:
    assert process.stdout is not None
    while await process.stdout.readline():
        pass


async def stop(process: asyncio.subprocess.Process) -> None:
    if process.returncode is None:
        process.send_signal(signal.SIGINT)
    await asyncio.wait_for(process.wait(), 120)


@contextlib.asynccontextmanager
async def stack() -> AsyncIterator[str]:
    up = await start(
        sys.executable, "-m", "clients.stack.up_cli", "--host", "127.0.0.1", "--port", "0"
    )
    try:
        url = (await wait_line(up, r"connect to (ws://[\d.]+:\d+)"))[1].decode()
        pump = asyncio.create_task(drain(up))
        yield url
    finally:
        await stop(up)
    await pump


@contextlib.asynccontextmanager
async def bare_bridge() -> AsyncIterator[str]:
    bridge = await start(sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0")
    try:
        port = (await wait_line(bridge, r"listening on ws://127\.0\.0\.1:(\d+)"))[1].decode()
        pump = asyncio.create_task(drain(bridge))
        yield f"ws://127.0.0.1:{port}"
    finally:
        await stop(bridge)
    await pump


async def publish_scans(url: str, scan_hz: float, stop_at: asyncio.Event) -> None:
    """Thesis-sized scans at ``scan_hz`` and IMU samples at 100 Hz until ``stop_at``."""
    data = np.random.default_rng(0).random((SCAN_POINTS, 4), dtype=np.float32).tobytes()
    fields = [
        {"name": n, "offset": 4 * i, "datatype": 7, "count": 1}
        for i, n in enumerate(("x", "y", "z", "intensity"))
    ]
    async with RosbridgeClient(url, name="scans") as scans, RosbridgeClient(url, name="imu") as imu:
        await scans.advertise("/lidar/points", "sensor_msgs/msg/PointCloud2", latest_only=True)
        await imu.advertise("/imu/data", "sensor_msgs/msg/Imu")

        async def imu_loop() -> None:
            while not stop_at.is_set():
                stamp = ns_to_stamp(time.time_ns())
                await imu.publish("/imu/data", {"header": {"stamp": stamp, "frame_id": "imu"}})
                await asyncio.sleep(0.01)

        task = asyncio.create_task(imu_loop())
        loop = asyncio.get_running_loop()
        next_s = loop.time()
        while not stop_at.is_set():
            await scans.publish(
                "/lidar/points",
                {
                    "header": {"stamp": ns_to_stamp(time.time_ns()), "frame_id": "lidar"},
                    "height": 1,
                    "width": SCAN_POINTS,
                    "fields": fields,
                    "point_step": 16,
                    "row_step": 16 * SCAN_POINTS,
                    "data": data,
                    "is_dense": True,
                },
            )
            next_s += 1 / scan_hz
            await asyncio.sleep(max(0.0, next_s - loop.time()))
        task.cancel()


async def bridge_stats(url: str) -> dict:
    async with RosbridgeClient(url, name="bench-stats", reconnect=False) as client:
        return await client.call_service(STATS_SERVICE, type=STATS_SERVICE_TYPE, timeout=20)


def counts_in(stats: dict) -> Counter[str]:
    return Counter(dict(zip(stats["topics"], stats["messages_in"], strict=True)))


def bridge_drops(stats: dict) -> Counter[str]:
    """Messages the bridge dropped per topic for slow subscribers (all of them)."""
    drops: Counter[str] = Counter()
    for topic, count in zip(stats["drop_topics"], stats["drops"], strict=True):
        drops[topic] += count
    return drops


def file_counts(path: Path, start_ns: int, end_ns: int) -> tuple[Counter[str], int]:
    """Messages per topic whose publish_time is in [start, end), and their CDR bytes."""
    counts: Counter[str] = Counter()
    size = 0
    with open(path, "rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            if start_ns <= message.publish_time < end_ns:
                counts[channel.topic] += 1
                size += len(message.data)
    return counts, size


async def measure(url: str, args: argparse.Namespace, label: str) -> None:
    output = Path(tempfile.mkdtemp()) / "bench.mcap"
    recorder = await start(
        sys.executable,
        "-m",
        "clients.recording.record_cli",
        "--bridge",
        url,
        "--output",
        str(output),
        "--compression",
        args.compression,
    )
    await wait_line(recorder, r"recording /rosout")
    pump = asyncio.create_task(drain(recorder))
    await asyncio.sleep(args.warmup)
    with burning(args.burn):
        first, start_ns, cpu0 = await bridge_stats(url), time.time_ns(), cpu_seconds(recorder.pid)
        await asyncio.sleep(args.window)
        last, end_ns, cpu1 = await bridge_stats(url), time.time_ns(), cpu_seconds(recorder.pid)
        load = os.getloadavg()
    await asyncio.sleep(3.0)  # what is still on its way to the recorder
    dropped = bridge_drops(await bridge_stats(url)) - bridge_drops(first)
    await stop(recorder)
    await pump
    before, after = counts_in(first), counts_in(last)
    recorded, size = file_counts(output, start_ns, end_ns)
    window_s = (end_ns - start_ns) / NS_PER_S
    print(
        f"\n== {label}: {window_s:.1f} s window, load {load[0]:.2f} (1 min), "
        f"{args.burn} busy processes, {args.compression}"
    )
    print(
        f"   {'topic':<30}{'bridge in':>10}{'recorded':>10}{'ratio':>8}"
        f"{'bridge dropped (any subscriber)':>33}"
    )
    for topic in sorted(set(after) | set(recorded)):
        got = after[topic] - before[topic]
        if got or recorded[topic]:
            ratio = recorded[topic] / got if got else float("nan")
            print(f"   {topic:<30}{got:>10}{recorded[topic]:>10}{ratio:>8.3f}{dropped[topic]:>33}")
    total = sum(recorded.values())
    print(
        f"   recorder: {total / window_s:.0f} msg/s, {size / window_s / 1e6:.1f} MB/s CDR, "
        f"CPU {100 * (cpu1 - cpu0) / window_s:.0f} % of a core; file "
        f"{output.stat().st_size / 1e6:.1f} MB for the whole run"
    )
    output.unlink()


def _burn() -> None:
    while True:
        pass


@contextlib.contextmanager
def burning(count: int) -> Iterator[None]:
    workers = [multiprocessing.Process(target=_burn, daemon=True) for _ in range(count)]
    for worker in workers:
        worker.start()
    try:
        yield
    finally:
        for worker in workers:
            worker.terminate()
            worker.join()


async def main(args: argparse.Namespace) -> None:
    if args.case in ("stack", "all"):
        async with stack() as url:
            await measure(url, args, "stack: riverbridge up, every topic")
    if args.case in ("scans", "all"):
        for scan_hz in args.scan_hz:
            async with bare_bridge() as url:
                stop_at = asyncio.Event()
                publisher = asyncio.create_task(publish_scans(url, scan_hz, stop_at))
                try:
                    await measure(
                        url, args, f"scans: 5.5 MB PointCloud2 at {scan_hz:g} Hz + IMU 100 Hz"
                    )
                finally:
                    stop_at.set()
                    await publisher


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--window", type=float, default=20.0, help="seconds measured")
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--case", choices=("stack", "scans", "all"), default="all")
    parser.add_argument("--scan-hz", type=float, nargs="+", default=[2.0, 5.0, 10.0])
    parser.add_argument("--burn", type=int, default=0, help="busy processes during the window")
    parser.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")
    asyncio.run(main(parser.parse_args()))
