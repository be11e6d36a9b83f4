"""IMU age and bridge CPU per message: a Foxglove subscriber against a rosbridge `cbor-raw` one.

One `python -m bridge` process (glibc malloc tuned) and a bare websockets relay (the floor,
`benchmarks.relay.floor_relay`: forwards frames as they came, validates and encodes nothing).
A CBOR publisher sends a `sensor_msgs/msg/Imu` at `--imu-hz` stamped at the moment it is
encoded, beside a PointCloud2 scan (`--scan-points`, x/y/z/intensity float32) at `--scan-hz`;
one subscriber of both topics reads, in turn:

- `floor`: the bare relay's copy of the publisher's CBOR frames;
- `cbor-raw`: a rosbridge v2 subscriber with `compression: cbor-raw` (the message's CDR);
- `foxglove`: a `foxglove.websocket.v1` subscriber (MessageData around the same CDR).

The subscriber reads the IMU's `header.stamp` (from the CDR, or the CBOR for the floor) and
records its age at receipt on this host's wall clock. Runs are interleaved (floor, cbor-raw,
foxglove, repeated `--repeat` times) and each prints per-run figures; the table gives the
medians over runs of IMU age p50/p99 (ms) and the relay's CPU per delivered message (µs:
user+system time of its process over the window, from /proc), with ratios to the floor.

Usage: python -m benchmarks.foxglove [--seconds 8] [--repeat 3] [--imu-hz 200]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import multiprocessing
import os
import statistics
import struct
import time
from dataclasses import dataclass
from typing import Any

import cbor2
import numpy as np
import websockets

from benchmarks.relay import run_floor, start_bridge
from schemas import codec_cbor
from schemas.pointcloud import pack_points

IMU_TOPIC, IMU_TYPE = "/bench/imu", "sensor_msgs/msg/Imu"
SCAN_TOPIC, SCAN_TYPE = "/bench/scan", "sensor_msgs/msg/PointCloud2"
FOXGLOVE = "foxglove.websocket.v1"
STAMP = struct.Struct("<iI")  # builtin_interfaces/Time right after the 4-byte CDR header
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")
MODES = ("floor", "cbor-raw", "foxglove")


@dataclass
class Run:
    ages_ms: list[float]
    messages: int
    cpu_s: float


def stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process `pid` so far."""
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


async def publish(url: str, imu_hz: float, scan_hz: float, scan: dict, stop: asyncio.Event) -> None:
    """The IMU at `imu_hz` (stamped as it is encoded) and the scan at `scan_hz`, as CBOR."""
    async with websockets.connect(url, compression=None, max_size=None) as ws:
        for topic, type_name in ((IMU_TOPIC, IMU_TYPE), (SCAN_TOPIC, SCAN_TYPE)):
            await ws.send(json.dumps({"op": "advertise", "topic": topic, "type": type_name}))
        period_s, tick = 1.0 / imu_hz, 0
        every = max(1, round(imu_hz / scan_hz)) if scan_hz > 0 else 0  # 0: no scan
        next_s = time.perf_counter()
        while not stop.is_set():
            if every and tick % every == 0:
                msg = {**scan, "header": {"stamp": stamp(time.time_ns()), "frame_id": "lidar"}}
                await ws.send(codec_cbor.dumps({"op": "publish", "topic": SCAN_TOPIC, "msg": msg}))
            imu = {"header": {"stamp": stamp(time.time_ns()), "frame_id": "imu"}}
            await ws.send(codec_cbor.dumps({"op": "publish", "topic": IMU_TOPIC, "msg": imu}))
            tick += 1
            next_s += period_s
            await asyncio.sleep(max(0.0, next_s - time.perf_counter()))


async def subscribe(mode: str, url: str) -> Any:
    """A connected subscriber of both topics; what it receives tells IMU from scan."""
    if mode != "foxglove":
        ws = await websockets.connect(url, compression=None, max_size=None)
        compression = "cbor-raw" if mode == "cbor-raw" else "cbor"
        for topic, type_name in ((IMU_TOPIC, IMU_TYPE), (SCAN_TOPIC, SCAN_TYPE)):
            op = {"op": "subscribe", "topic": topic, "type": type_name, "compression": compression}
            await ws.send(json.dumps(op))
        return ws
    ws = await websockets.connect(url, compression=None, max_size=None, subprotocols=[FOXGLOVE])
    wanted = {IMU_TOPIC: 1, SCAN_TOPIC: 2}
    while wanted:
        data = await ws.recv()
        if isinstance(data, str) and (op := json.loads(data))["op"] == "advertise":
            found = [(c["topic"], c["id"]) for c in op["channels"] if c["topic"] in wanted]
            subs = [{"id": wanted.pop(topic), "channelId": cid} for topic, cid in found]
            if subs:
                await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
    return ws


def imu_stamp_ns(mode: str, data: bytes | str) -> int | None:
    """The IMU's header stamp in a received frame, None for a scan (or anything else)."""
    if mode == "foxglove":
        if not isinstance(data, bytes) or data[0] != 1 or data[1] != 1:  # subscription 1
            return None
        sec, nanosec = STAMP.unpack_from(data, 13 + 4)
        return sec * 1_000_000_000 + nanosec
    if not isinstance(data, bytes):
        return None
    op = cbor2.loads(data)
    if op.get("topic") != IMU_TOPIC:
        return None
    if mode == "cbor-raw":
        sec, nanosec = STAMP.unpack_from(op["msg"]["bytes"], 4)
    else:
        sec, nanosec = op["msg"]["header"]["stamp"]["sec"], op["msg"]["header"]["stamp"]["nanosec"]
    return int(sec) * 1_000_000_000 + int(nanosec)


async def one_run(mode: str, url: str, pid: int, args: argparse.Namespace, scan: dict) -> Run:
    stop = asyncio.Event()
    publisher = asyncio.create_task(publish(url, args.imu_hz, args.scan_hz, scan, stop))
    ws = await subscribe(mode, url)  # (a Foxglove client waits for the channels)
    ages: list[float] = []
    messages = 0
    try:
        await asyncio.wait_for(ws.recv(), 10)  # flowing
        deadline = time.monotonic() + args.seconds
        cpu_before = cpu_seconds(pid)
        while time.monotonic() < deadline:
            data = await ws.recv()
            received_ns = time.time_ns()
            messages += 1
            sent_ns = imu_stamp_ns(mode, data)
            if sent_ns is not None:
                ages.append((received_ns - sent_ns) / 1e6)
        cpu_s = cpu_seconds(pid) - cpu_before
    finally:
        stop.set()
        await publisher
        await ws.close()
    return Run(ages, messages, cpu_s)


def figures(run: Run) -> dict[str, float]:
    ages = np.array(run.ages_ms)
    return {
        "p50_ms": float(np.percentile(ages, 50)),
        "p99_ms": float(np.percentile(ages, 99)),
        "cpu_us_per_msg": run.cpu_s / max(1, run.messages) * 1e6,
    }


async def measure(args: argparse.Namespace) -> dict[str, list[dict[str, float]]]:
    points = np.random.default_rng(1).random((args.scan_points, 4), dtype=np.float32)
    scan = pack_points(points, 0, "lidar")
    bridge, bridge_url = start_bridge([], None)
    parent, child = multiprocessing.Pipe()
    floor = multiprocessing.Process(target=run_floor, args=(child,), daemon=True)
    floor.start()
    floor_url = f"ws://127.0.0.1:{parent.recv()}"
    assert floor.pid is not None
    results: dict[str, list[dict[str, float]]] = {mode: [] for mode in MODES}
    try:
        for repeat in range(args.repeat):
            for mode in MODES:
                url, pid = (floor_url, floor.pid) if mode == "floor" else (bridge_url, bridge.pid)
                run = await one_run(mode, url, pid, args, scan)
                results[mode].append(figures(run))
                shown = ", ".join(f"{k} {v:.2f}" for k, v in results[mode][-1].items())
                print(f"run {repeat + 1} {mode:<9} {len(run.ages_ms)} IMU, {shown}", flush=True)
    finally:
        bridge.terminate()
        bridge.wait()
        floor.terminate()
    return results


def table(results: dict[str, list[dict[str, float]]]) -> list[str]:
    medians = {
        mode: {key: statistics.median(r[key] for r in runs) for key in runs[0]}
        for mode, runs in results.items()
    }
    floor = medians["floor"]
    lines = [f"{'subscriber':<10} {'IMU age p50':>14} {'IMU age p99':>14} {'CPU/msg':>16}"]
    for mode, m in medians.items():
        ratio = {k: m[k] / floor[k] if floor[k] else float("nan") for k in m}
        lines.append(
            f"{mode:<10} {m['p50_ms']:>6.2f} ms {ratio['p50_ms']:4.1f}x "
            f"{m['p99_ms']:>6.2f} ms {ratio['p99_ms']:4.1f}x "
            f"{m['cpu_us_per_msg']:>7.0f} µs {ratio['cpu_us_per_msg']:4.1f}x"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.foxglove", description=__doc__)
    parser.add_argument("--seconds", type=float, default=8.0, help="window per run")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds")
    parser.add_argument("--imu-hz", type=float, default=200.0)
    parser.add_argument("--scan-hz", type=float, default=2.0, help="0: the IMU alone")
    parser.add_argument("--scan-points", type=int, default=179_000, help="~ a full scan's hits")
    args = parser.parse_args(argv)
    with contextlib.suppress(FileNotFoundError), open("/proc/loadavg") as load:
        print(f"load average at start: {' '.join(load.read().split()[:3])}")
    results = asyncio.run(measure(args))
    with contextlib.suppress(FileNotFoundError), open("/proc/loadavg") as load:
        print(f"load average at end: {' '.join(load.read().split()[:3])}")
    print(f"medians of {args.repeat} interleaved runs; ratios to the bare relay (floor):")
    print("\n".join(table(results)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
