"""Relay through the bridge: one publisher process and one subscriber process, one websocket
each (as roslibjs, ROS#, Unity and Foxglove clients connect), JSON and CBOR.

Workloads (issue 11), each printed beside the reference rosbridge_suite 0.11.17 figures measured
on this machine in the issue:

1. burst: 15,000 ~100-byte ``std_msgs/String`` sent as fast as the publisher can while the
   subscriber reads as fast as it can: delivered, loss, delivered/s, ages;
2. sustained: the same messages for ``--seconds``, delivered/s and loss;
3. scan + IMU: a full 345,600-point ``sensor_msgs/PointCloud2`` (5.5 MB) at 2 Hz and a 50 Hz
   ``sensor_msgs/Imu`` on the same publisher connection and the same subscriber connection:
   scan age p50/p99/max and IMU age p99/max;
4. scan2 (only when asked for): the same with the scan and the IMU each on a connection of its
   own, in the publisher and in the subscriber: does a second connection still help?

Ages run from just before the publisher encodes (the stamp inside the message) to just after
the subscriber decoded, on one wall clock. The clients are plain ``websockets`` connections
that behave like a careful third-party client: big JSON frames are encoded and decoded on a worker
thread, in order, as riverbridge's own client library does, so the clients add as little as
they can.

Usage: python benchmarks/relay.py [--only burst,sustained,scan] [--encodings json,cbor]
       [--repeat N] [--compare /work/main] [--floor] [--url ws://host:port]
       [-- bridge options...]
With --repeat, --compare (another checkout's bridge) or --floor (a bare websockets relay that
forwards frames unvalidated), the relays run interleaved and the medians are printed side by
side with their ratios to this checkout's bridge.

Measured here, quiet (`--compare <checkout> --floor --repeat 3`, load 0.02-2.3 from the
benchmark itself; two sittings, medians of 3 interleaved runs each; "before" = the bridge
before issue 11, measured in an earlier sitting at load 1.2-3.4):

    workload          this bridge                before               bare relay (floor)
    burst JSON        15,000; 27,600-36,900/s    ~255 (98.3 % lost)   15,000; 46,100-53,400/s
    burst CBOR        15,000; 29,400-32,700/s    ~225 (98.5 % lost)   15,000; 40,900-46,900/s
    sustained JSON    35,300-37,800/s, lossless  320/s (99 % lost)    58,700-60,600/s
    sustained CBOR    34,700-35,200/s, lossless  350/s (99 % lost)    56,300-59,800/s
    scan+IMU JSON     scan p50 30.5-33.7 ms,     39.5 ms, 22.0 ms     29.3-31.4 ms, 7.0-7.1 ms
                      IMU p99 7.4-9.2 ms
    scan+IMU CBOR     scan p50 12.1-14.4 ms,     16.0 ms, 6.0 ms      11.9-12.5 ms, 2.2 ms
                      IMU p99 3.2-4.0 ms

The bare relay forwards the publisher's frame as it came and validates nothing: on one
connection its scan and IMU figures are what the clients, the copies and the kernel cost here.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import multiprocessing as mp
import os
import re
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

TUNED_MALLOC = {
    "MALLOC_MMAP_THRESHOLD_": "268435456",
    "MALLOC_TRIM_THRESHOLD_": "1073741824",
    "MALLOC_TOP_PAD_": "67108864",
}
SCAN_POINTS = 345_600  # the thesis' LIDAR (Table 4.3): x, y, z, intensity float32 -> 5.5 MB
# Frames from this size on are encoded/decoded on the client's thread, as riverbridge's own
# client library does (clients.client.OFFLOAD_BYTES): a JSON scan would hold the loop for ~5 ms,
# a CBOR one costs less than the thread hop.
BIG_FRAME_BYTES = {False: 256 * 1024, True: 8 * 1024 * 1024}
STRING_BYTES = 100
IDLE_END_S = 3.0  # the subscriber stops this long after the last frame once the publisher is done
WARMUP_S = 1.0  # scan workload: samples stamped in the first second are not counted

# Reference rosbridge_suite 0.11.17 figures from issue 11, same machine, one sitting.
REFERENCE = {
    "burst": "10,041 of 15,000 delivered",
    "sustained": "3,300-3,600 msg/s",
    "scan-cbor": "does not accept CBOR publishes",
    "scan-json": "scan p50 1,595 ms, IMU p99 546 ms",
    "scan2-cbor": "-",
    "scan2-json": "-",
}
TARGET = {
    "burst": "all 15,000 delivered",
    "sustained": ">= 20,000 msg/s, lossless",
    "scan-cbor": "scan p50 <= 12 ms, IMU p99 <= 5 ms",
    "scan-json": "scan p50 <= 45 ms, IMU p99 <= 5 ms",
    "scan2-cbor": "two connections each: does a second one still help?",
    "scan2-json": "two connections each: does a second one still help?",
}


# -- messages ----------------------------------------------------------------------------------


def stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def string_msg(seq: int) -> dict[str, str]:
    head = f"{seq:010d} {time.time_ns():019d} "
    return {"data": head + "x" * (STRING_BYTES - len(head))}


def imu_msg() -> dict[str, Any]:
    return {
        "header": {"stamp": stamp(time.time_ns()), "frame_id": "imu"},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "angular_velocity": {"x": 0.01, "y": 0.02, "z": 0.03},
        "linear_acceleration": {"x": 0.1, "y": 0.2, "z": 9.81},
    }


def scan_msg(data: bytes) -> dict[str, Any]:
    fields = [
        {"name": n, "offset": 4 * i, "datatype": 7, "count": 1}
        for i, n in enumerate(["x", "y", "z", "intensity"])
    ]
    return {
        "header": {"stamp": stamp(time.time_ns()), "frame_id": "lidar"},
        "height": 1,
        "width": SCAN_POINTS,
        "fields": fields,
        "is_bigendian": False,
        "point_step": 16,
        "row_step": 16 * SCAN_POINTS,
        "data": data,
        "is_dense": True,
    }


def sent_ns(topic: str, msg: dict[str, Any]) -> tuple[int, int]:
    """(sequence number or -1, publisher stamp in ns) of a received message."""
    if topic == "/chatter":
        data = msg["data"]
        return int(data[:10]), int(data[11:30])
    head = msg["header"]["stamp"]
    return -1, head["sec"] * 1_000_000_000 + head["nanosec"]


# -- a careful raw client ------------------------------------------------------------------------


class RawClient:
    """One websocket; big frames encoded and decoded on one thread each, order kept."""

    def __init__(self, url: str, binary: bool) -> None:
        self.url = url
        self.binary = binary
        self.ws: Any = None
        self._encoder = ThreadPoolExecutor(1)
        self._decoder = ThreadPoolExecutor(1)
        self._tasks: list[asyncio.Task[None]] = []

    async def __aenter__(self) -> RawClient:
        import websockets

        self.ws = await websockets.connect(self.url, max_size=None, compression=None, max_queue=64)
        return self

    async def __aexit__(self, *exc: object) -> None:
        for task in self._tasks:
            task.cancel()
        await self.ws.close()
        self._encoder.shutdown()
        self._decoder.shutdown()

    def _encode(self, op: dict[str, Any]) -> bytes | str:
        from schemas import codec_cbor, codec_json

        if self.binary and op["op"] == "publish":
            return codec_cbor.dumps(op)
        return codec_json.dumps(op).decode("ascii")

    async def send(self, op: dict[str, Any], big: bool = False) -> None:
        if big and not self.binary:
            frame = await asyncio.get_running_loop().run_in_executor(
                self._encoder, self._encode, op
            )
        else:
            frame = self._encode(op)
        await self.ws.send(frame)

    async def call(self, service: str) -> None:
        """A round trip: everything sent before it has been handled by the bridge."""
        await self.send({"op": "call_service", "service": service, "id": "sync"})

    def read(self, handle: Callable[[int, Any], None]) -> None:
        """Call `handle(decoded_ns, op)` for every frame, from the reading task. Small frames
        are decoded at once and overtake big ones being decoded on the thread (big frames
        keep their own order)."""
        from schemas import codec_cbor, codec_json

        def decode(data: bytes | str) -> Any:
            return codec_json.loads(data) if isinstance(data, str) else codec_cbor.loads(data)

        loop = asyncio.get_running_loop()
        big: asyncio.Queue[asyncio.Future[Any]] = asyncio.Queue()

        async def read() -> None:
            async for data in self.ws:
                if len(data) >= BIG_FRAME_BYTES[self.binary]:
                    big.put_nowait(loop.run_in_executor(self._decoder, decode, data))
                else:
                    handle(time.time_ns(), decode(data))

        async def finish_big() -> None:
            while True:
                op = await (await big.get())
                handle(time.time_ns(), op)

        self._tasks = [asyncio.create_task(read()), asyncio.create_task(finish_big())]


# -- the two roles ---------------------------------------------------------------------------------


@dataclass
class Received:
    """What a subscriber saw of one topic."""

    count: int = 0
    out_of_order: int = 0
    last_seq: int = -1
    first_ns: int = 0
    last_ns: int = 0
    ages_ms: list[float] = field(default_factory=list)


def connection_groups(workload: str) -> list[list[tuple[str, str]]]:
    """The topics of each connection a client opens: one, or (scan2) the scan and the IMU
    on connections of their own."""
    topics = TOPICS[workload]
    return [[topic] for topic in topics] if workload == "scan2" else [topics]


async def subscriber(pipe: Connection, url: str, binary: bool, workload: str) -> None:
    compression = "cbor" if binary else "none"
    seen: dict[str, Received] = {t: Received() for t, _ in TOPICS[workload]}
    subscribed = asyncio.Semaphore(0)
    last_frame = [time.monotonic()]

    def handle(recv_ns: int, op: Any) -> None:
        if op.get("op") == "publish":
            record(seen[op["topic"]], recv_ns, *sent_ns(op["topic"], op["msg"]))
            last_frame[0] = time.monotonic()
        elif op.get("op") == "service_response":
            subscribed.release()  # the round trip's answer: the subscriptions are in place

    async with contextlib.AsyncExitStack() as stack:
        for group in connection_groups(workload):
            sub = await stack.enter_async_context(RawClient(url, binary))
            sub.read(handle)
            for topic, type_name in group:
                await sub.send(
                    {
                        "op": "subscribe",
                        "topic": topic,
                        "type": type_name,
                        "compression": compression,
                    }
                )
            await sub.call("/rosapi/get_time")
            await subscribed.acquire()
        started_cpu_s = cpu_s()
        pipe.send("ready")
        expected = await asyncio.to_thread(pipe.recv)
        while not all(seen[t].count >= n for t, n in expected.items()):
            if time.monotonic() - last_frame[0] > IDLE_END_S:
                break
            await asyncio.sleep(0.05)
        used_cpu_s = cpu_s() - started_cpu_s
    pipe.send(({t: r.__dict__ for t, r in seen.items()}, used_cpu_s))


def record(seen: Received, recv_ns: int, seq: int, stamp_ns: int) -> None:
    seen.count += 1
    if seq >= 0:
        if seq <= seen.last_seq:
            seen.out_of_order += 1
        seen.last_seq = seq
    seen.first_ns = seen.first_ns or recv_ns
    seen.last_ns = recv_ns
    seen.ages_ms.append((recv_ns - stamp_ns) / 1e6)


async def publish_strings(pub: Any, count: int | None, seconds: float | None) -> int:
    """Send as fast as the connection takes them: `count` messages or for `seconds`."""
    end = None if seconds is None else time.monotonic() + seconds
    seq = 0
    while (count is None or seq < count) and (end is None or time.monotonic() < end):
        await pub.send({"op": "publish", "topic": "/chatter", "msg": string_msg(seq)})
        seq += 1
    return seq


async def publish_scan_imu(pub: Any, imu_pub: Any, seconds: float) -> dict[str, int]:
    """2 Hz scans on `pub` and 50 Hz IMU on `imu_pub` (the same connection, or not)."""
    data = np.random.default_rng(0).random(SCAN_POINTS * 4, dtype=np.float32).tobytes()
    end = time.monotonic() + seconds
    sent = {"/lidar": 0, "/imu": 0}

    async def scans() -> None:
        next_at = time.monotonic()
        while next_at < end:
            await pub.send({"op": "publish", "topic": "/lidar", "msg": scan_msg(data)}, big=True)
            sent["/lidar"] += 1
            next_at += 0.5
            await asyncio.sleep(max(0.0, next_at - time.monotonic()))

    async def imus() -> None:
        next_at = time.monotonic()
        while next_at < end:
            await imu_pub.send({"op": "publish", "topic": "/imu", "msg": imu_msg()})
            sent["/imu"] += 1
            next_at += 0.02
            await asyncio.sleep(max(0.0, next_at - time.monotonic()))

    await asyncio.gather(scans(), imus())
    return sent


async def publisher(
    pipe: Connection, url: str, binary: bool, workload: str, count: int, seconds: float
) -> None:
    async with contextlib.AsyncExitStack() as stack:
        pubs = []
        for group in connection_groups(workload):
            pub = await stack.enter_async_context(RawClient(url, binary))
            for topic, type_name in group:
                await pub.send({"op": "advertise", "topic": topic, "type": type_name})
            pubs.append(pub)
        started_cpu_s = cpu_s()
        started = time.monotonic()
        if workload == "burst":
            sent = {"/chatter": await publish_strings(pubs[0], count, None)}
        elif workload == "sustained":
            sent = {"/chatter": await publish_strings(pubs[0], None, seconds)}
        else:
            sent = await publish_scan_imu(pubs[0], pubs[-1], seconds)
        elapsed = time.monotonic() - started
        for pub in pubs:
            await pub.call("/rosapi/get_time")
        await asyncio.sleep(0.2)
        used_cpu_s = cpu_s() - started_cpu_s
    pipe.send((sent, elapsed, used_cpu_s))


TOPICS = {
    "burst": [("/chatter", "std_msgs/msg/String")],
    "sustained": [("/chatter", "std_msgs/msg/String")],
    "scan": [("/lidar", "sensor_msgs/msg/PointCloud2"), ("/imu", "sensor_msgs/msg/Imu")],
    "scan2": [("/lidar", "sensor_msgs/msg/PointCloud2"), ("/imu", "sensor_msgs/msg/Imu")],
}


def cpu_s(pid: int | None = None) -> float:
    """CPU seconds (user + system) used by this process, or by process `pid`."""
    if pid is None:
        usage = resource.getrusage(resource.RUSAGE_SELF)
        return usage.ru_utime + usage.ru_stime
    with open(f"/proc/{pid}/stat") as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_role(role: str, pipe: Connection, *args: Any) -> None:
    """Entry point of a spawned process: tuned like every riverbridge process."""
    from schemas.runtime.process import freeze_startup_heap, tune_process

    tune_process()
    freeze_startup_heap()
    asyncio.run((subscriber if role == "sub" else publisher)(pipe, *args))


# -- orchestration -----------------------------------------------------------------------------


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def one_run(
    url: str, workload: str, encoding: str, args: argparse.Namespace, bridge_pid: int | None
) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    binary = encoding == "cbor"
    sub_end, sub_pipe = ctx.Pipe()
    pub_end, pub_pipe = ctx.Pipe()
    sub = ctx.Process(target=run_role, args=("sub", sub_pipe, url, binary, workload))
    sub.start()
    if not sub_end.poll(30) or sub_end.recv() != "ready":
        raise RuntimeError("subscriber did not start")
    bridge_cpu = cpu_s(bridge_pid) if bridge_pid else float("nan")
    pub = ctx.Process(
        target=run_role, args=("pub", pub_pipe, url, binary, workload, args.count, args.seconds)
    )
    pub.start()
    sent, elapsed, pub_cpu = pub_end.recv()
    sub_end.send(sent)
    seen, sub_cpu = sub_end.recv()
    bridge_cpu = (cpu_s(bridge_pid) if bridge_pid else float("nan")) - bridge_cpu
    pub.join(10)
    sub.join(10)
    return {
        "sent": sent,
        "elapsed_s": elapsed,
        "seen": seen,
        "cpu_s": {"bridge": bridge_cpu, "publisher": pub_cpu, "subscriber": sub_cpu},
    }


def summarize(workload: str, encoding: str, result: dict[str, Any]) -> list[str]:
    sent, seen = result["sent"], result["seen"]
    lines = []
    for topic, n_sent in sent.items():
        got = seen[topic]
        ages = got["ages_ms"]
        if workload.startswith("scan"):
            ages = ages[int(WARMUP_S * (2 if topic == "/lidar" else 50)) :]
        span_s = max(1e-9, (got["last_ns"] - got["first_ns"]) / 1e9)
        loss = n_sent - got["count"]
        lines.append(
            f"  {topic:<9} sent {n_sent:>7,} in {result['elapsed_s']:5.2f} s  delivered "
            f"{got['count']:>7,} ({got['count'] / span_s:>8,.0f}/s)  loss {loss:>6,} "
            f"({100 * loss / max(1, n_sent):4.1f} %)  out of order {got['out_of_order']}  "
            f"age p50 {percentile(ages, 50):7.1f}  p99 {percentile(ages, 99):7.1f}  "
            f"max {max(ages, default=float('nan')):7.1f} ms"
        )
    cpu = result["cpu_s"]
    lines.append(
        "  CPU s: "
        + ", ".join(f"{name} {seconds:.2f}" for name, seconds in cpu.items())
        + " (from connected to done)"
    )
    key = workload if not workload.startswith("scan") else f"{workload}-{encoding}"
    lines.append(f"  reference rosbridge: {REFERENCE[key]}; target: {TARGET[key]}")
    return lines


def start_bridge(extra: list[str], root: str | None) -> tuple[subprocess.Popen[str], str]:
    env = {**os.environ, **TUNED_MALLOC}
    if root is not None:  # another checkout's bridge (e.g. main, for a before/after)
        root = os.path.abspath(root)
        env["PYTHONPATH"] = root
    process = subprocess.Popen(
        [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "warning", *extra],
        stderr=subprocess.PIPE,
        env=env,
        text=True,
        cwd=root,
    )
    assert process.stderr is not None
    for line in process.stderr:
        match = re.search(r"listening on (ws://\S+)", line)
        if match:
            return process, match.group(1)
    raise RuntimeError("bridge exited before listening")


async def floor_relay(pipe: Connection) -> None:
    """The floor: a bare websockets relay that forwards publish frames as they came, without
    validation or re-encoding, and answers every call (the issue's "40-line relay")."""
    import cbor2
    import orjson
    from websockets.asyncio.server import serve
    from websockets.exceptions import ConnectionClosed

    subscribers: dict[str, set[Any]] = {}

    async def relay(ws: Any) -> None:
        async for data in ws:
            op = orjson.loads(data) if isinstance(data, str) else cbor2.loads(data)
            if op["op"] == "publish":
                for sub in list(subscribers.get(op["topic"], ())):
                    with contextlib.suppress(ConnectionClosed):
                        await sub.send(data)
            elif op["op"] == "subscribe":
                subscribers.setdefault(op["topic"], set()).add(ws)
            elif op["op"] == "call_service":
                with contextlib.suppress(ConnectionClosed):
                    await ws.send(
                        orjson.dumps(
                            {
                                "op": "service_response",
                                "id": op.get("id"),
                                "service": op["service"],
                                "values": {},
                                "result": True,
                            }
                        ).decode()
                    )
        for subs in subscribers.values():
            subs.discard(ws)

    async with serve(
        relay, "127.0.0.1", 0, compression=None, max_size=None, write_limit=1024 * 1024
    ) as server:
        pipe.send(server.sockets[0].getsockname()[1])
        await asyncio.Future()


def run_floor(pipe: Connection) -> None:
    asyncio.run(floor_relay(pipe))


@dataclass
class Target:
    """A relay under test: its label, URL and (if we started it) process id."""

    label: str
    url: str
    pid: int | None
    stop: Callable[[], None]


def start_targets(args: argparse.Namespace) -> list[Target]:
    targets = []
    if args.url:
        targets.append(Target("given", args.url, None, lambda: None))
    else:
        process, url = start_bridge(args.bridge_args, None)
        targets.append(Target("this", url, process.pid, process.terminate))
    if args.compare:
        process, url = start_bridge(args.bridge_args, args.compare)
        targets.append(
            Target(
                os.path.basename(os.path.abspath(args.compare)), url, process.pid, process.terminate
            )
        )
    if args.floor:
        ctx = mp.get_context("spawn")
        end, pipe = ctx.Pipe()
        floor = ctx.Process(target=run_floor, args=(pipe,), daemon=True)
        floor.start()
        targets.append(Target("floor", f"ws://127.0.0.1:{end.recv()}", floor.pid, floor.terminate))
    return targets


def metrics(workload: str, result: dict[str, Any]) -> dict[str, float]:
    """The figures of one run, flat: delivered/s, loss %, ages per topic; CPU per process."""
    out: dict[str, float] = {}
    for topic, n_sent in result["sent"].items():
        got = result["seen"][topic]
        ages = got["ages_ms"]
        if workload.startswith("scan"):
            ages = ages[int(WARMUP_S * (2 if topic == "/lidar" else 50)) :]
        span_s = max(1e-9, (got["last_ns"] - got["first_ns"]) / 1e9)
        out[f"{topic} delivered/s"] = got["count"] / span_s
        out[f"{topic} loss %"] = 100 * (n_sent - got["count"]) / max(1, n_sent)
        for name, q in (("p50", 50), ("p99", 99), ("max", 100)):
            out[f"{topic} age {name} ms"] = percentile(ages, q)
    for name, seconds in result["cpu_s"].items():
        out[f"CPU s {name}"] = seconds
    return out


def median_table(targets: list[Target], runs: dict[str, list[dict[str, float]]]) -> list[str]:
    """Medians per target, and each target's ratio to the first."""
    labels = [t.label for t in targets]
    head = (
        f"  {'median of ' + str(len(runs[labels[0]])) + ' runs':<28}"
        + "".join(f"{label:>12}" for label in labels)
        + "".join(f"{label + '/' + labels[0]:>14}" for label in labels[1:])
    )
    lines = [head]
    for key in runs[labels[0]][0]:
        medians = [float(np.median([run[key] for run in runs[label]])) for label in labels]
        ratios = [m / medians[0] if medians[0] else float("nan") for m in medians[1:]]
        lines.append(
            f"  {key:<28}"
            + "".join(f"{m:>12,.1f}" for m in medians)
            + "".join(f"{r:>14.2f}" for r in ratios)
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        default="burst,sustained,scan",
        help="comma-separated workloads (default %(default)s)",
    )
    parser.add_argument("--encodings", default="json,cbor", help="default %(default)s")
    parser.add_argument("--count", type=int, default=15_000, help="burst size")
    parser.add_argument(
        "--seconds", type=float, default=8.0, help="duration of the sustained and scan workloads"
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs per workload and relay; with more than one, print medians",
    )
    parser.add_argument(
        "--interleave",
        action="store_true",
        help="with --repeat: run every workload once per round (for comparing "
        "workloads, e.g. scan against scan2, under the same load)",
    )
    parser.add_argument("--url", help="use a running bridge instead of starting one")
    parser.add_argument(
        "--compare",
        metavar="DIR",
        help="also run the bridge of another checkout (e.g. /work/main), "
        "interleaved, and print ratios",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="also run a bare websockets relay (no validation), the floor",
    )
    parser.add_argument("bridge_args", nargs="*", help="options for `python -m bridge`")
    args = parser.parse_args(argv)
    os.environ.update(TUNED_MALLOC)  # the client processes move megabytes too
    targets = start_targets(args)
    try:
        print(
            f"relays: {', '.join(f'{t.label} {t.url}' for t in targets)} "
            f"{' '.join(args.bridge_args)}; load average {os.getloadavg()[0]:.2f} (1 min)"
        )
        cases = [(w, e) for w in args.only.split(",") for e in args.encodings.split(",")]
        if args.interleave:  # every case once per round, so a change of load hits them all
            runs = {case: new_runs(targets) for case in cases}
            for _ in range(args.repeat):
                for case in cases:
                    run_case(targets, *case, args, runs[case])
            for case in cases:
                print_case(targets, *case, runs[case])
        else:
            for case in cases:
                runs = new_runs(targets)
                for _ in range(args.repeat):
                    run_case(targets, *case, args, runs)
                print_case(targets, *case, runs)
    finally:
        for target in targets:
            target.stop()
    return 0


Runs = dict[str, Any]  # per target label: list of metrics dicts, and "loads"


def new_runs(targets: list[Target]) -> Runs:
    return {"loads": [], **{t.label: [] for t in targets}}


def run_case(
    targets: list[Target], workload: str, encoding: str, args: argparse.Namespace, runs: Runs
) -> None:
    """One run of the case on every target (in turn), appended to `runs`."""
    for target in targets:
        result = one_run(target.url, workload, encoding, args, target.pid)
        runs["loads"].append(os.getloadavg()[0])
        runs[target.label].append(metrics(workload, result))
        runs.setdefault("last", result)


def print_case(targets: list[Target], workload: str, encoding: str, runs: Runs) -> None:
    loads = runs["loads"]
    if len(loads) == 1:
        print(f"{workload} {encoding}  (load {loads[0]:.2f})")
        print("\n".join(summarize(workload, encoding, runs["last"])), flush=True)
        return
    key = workload if not workload.startswith("scan") else f"{workload}-{encoding}"
    print(
        f"{workload} {encoding}  (load {min(loads):.2f}-{max(loads):.2f}); reference "
        f"rosbridge: {REFERENCE[key]}; target: {TARGET[key]}"
    )
    print("\n".join(median_table(targets, {t.label: runs[t.label] for t in targets})), flush=True)


if __name__ == "__main__":
    sys.exit(main())
