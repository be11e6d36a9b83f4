"""The two client processes of `benchmarks/relay.py`: a publisher and a subscriber, one
websocket each (two with ``scan2``, sixteen subscribers with ``fanout``; with ``service`` a
caller and a provider), behaving like a careful third-party rosbridge client.

Big JSON frames are encoded and decoded on a thread of their own, in order, as riverbridge's
own client library does, so the clients add as little as they can to the ages measured. Each
role runs in a spawned process (`run_role`) and reports through a pipe.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import resource
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from schemas import codec_cbor, codec_json
from schemas.pointcloud import pack_points

SCAN_POINTS = 345_600  # the thesis' LIDAR (Table 4.3): x, y, z, intensity float32 -> 5.5 MB
# Frames from this size on are encoded/decoded on the client's thread, as riverbridge's own
# client library does (clients.client.OFFLOAD_BYTES): a JSON scan would hold the loop for ~5 ms,
# a CBOR one costs less than the thread hop.
BIG_FRAME_BYTES = {False: 256 * 1024, True: 8 * 1024 * 1024}
STRING_BYTES = 100
IDLE_END_S = 3.0  # the subscriber stops this long after the last frame once the publisher is done


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


def scan_msg(cloud: dict[str, Any]) -> dict[str, Any]:
    """`cloud` (`schemas.pointcloud.pack_points`, packed once) stamped now."""
    return {**cloud, "header": {"stamp": stamp(time.time_ns()), "frame_id": "lidar"}}


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


# Subscriber connections per workload: `fanout` is the scan and the IMU to 16 subscribers,
# four connections in each of four processes (one process could not decode 64 MB/s here).
FANOUT = {"fanout": 16}
SUBSCRIBER_PROCESSES = {"fanout": 4}


def connection_groups(workload: str, role: str = "pub") -> list[list[tuple[str, str]]]:
    """The topics of each connection a client opens: one, (scan2) the scan and the IMU on
    connections of their own, or (fanout, subscriber) 16 connections taking both."""
    topics = TOPICS[workload]
    if workload == "scan2":
        return [[topic] for topic in topics]
    if role == "pub":
        return [topics]
    return [topics] * (FANOUT.get(workload, 1) // SUBSCRIBER_PROCESSES.get(workload, 1))


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

    if workload == "service":
        await provider(pipe, url)
        return
    async with contextlib.AsyncExitStack() as stack:
        for group in connection_groups(workload, "sub"):
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
        copies = len(connection_groups(workload, "sub"))
        while not all(seen[t].count >= n * copies for t, n in expected.items()):
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
    points = np.random.default_rng(0).random((SCAN_POINTS, 4), dtype=np.float32)
    cloud = pack_points(points, 0, "lidar")
    end = time.monotonic() + seconds
    sent = {"/lidar": 0, "/imu": 0}

    async def scans() -> None:
        next_at = time.monotonic()
        while next_at < end:
            await pub.send({"op": "publish", "topic": "/lidar", "msg": scan_msg(cloud)}, big=True)
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


SERVICE, SERVICE_TYPE = "/bench/trigger", "std_srvs/srv/Trigger"


async def provider(pipe: Connection, url: str) -> None:
    """The `service` workload's provider: answers every call at once, from its reading task."""
    answered = Received()
    async with RawClient(url, False) as client:
        ready = asyncio.Event()

        def handle(recv_ns: int, op: Any) -> None:
            if op.get("op") == "call_service":
                answered.count += 1
                reply = {
                    "op": "service_response",
                    "service": op["service"],
                    "id": op.get("id"),
                    "values": {"success": True, "message": ""},
                    "result": True,
                }
                asyncio.get_running_loop().create_task(client.send(reply))
            elif op.get("op") == "service_response":
                ready.set()

        client.read(handle)
        await client.send({"op": "advertise_service", "service": SERVICE, "type": SERVICE_TYPE})
        await client.call("/rosapi/get_time")
        await ready.wait()
        started_cpu_s = cpu_s()
        pipe.send("ready")
        await asyncio.to_thread(pipe.recv)
        used_cpu_s = cpu_s() - started_cpu_s
    pipe.send(({SERVICE: answered.__dict__}, used_cpu_s))


async def call_in_turn(client: RawClient, seconds: float) -> list[float]:
    """Call the service one call at a time for `seconds`; the round trips in ms."""
    answers: asyncio.Queue[int] = asyncio.Queue()
    client.read(lambda recv_ns, op: answers.put_nowait(recv_ns))
    rtts_ms: list[float] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        sent_ns = time.time_ns()
        await client.send({"op": "call_service", "service": SERVICE, "id": f"c{len(rtts_ms)}"})
        rtts_ms.append((await answers.get() - sent_ns) / 1e6)
    return rtts_ms


async def publisher(
    pipe: Connection, url: str, binary: bool, workload: str, count: int, seconds: float
) -> None:
    if workload == "service":
        async with RawClient(url, False) as caller:
            started_cpu_s, started = cpu_s(), time.monotonic()
            rtts_ms = await call_in_turn(caller, seconds)
            elapsed = time.monotonic() - started
        pipe.send(({SERVICE: len(rtts_ms)}, elapsed, cpu_s() - started_cpu_s, rtts_ms))
        return
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
    pipe.send((sent, elapsed, used_cpu_s, []))


TOPICS = {
    "burst": [("/chatter", "std_msgs/msg/String")],
    "sustained": [("/chatter", "std_msgs/msg/String")],
    "scan": [("/lidar", "sensor_msgs/msg/PointCloud2"), ("/imu", "sensor_msgs/msg/Imu")],
    "scan2": [("/lidar", "sensor_msgs/msg/PointCloud2"), ("/imu", "sensor_msgs/msg/Imu")],
    "fanout": [("/lidar", "sensor_msgs/msg/PointCloud2"), ("/imu", "sensor_msgs/msg/Imu")],
    "service": [(SERVICE, SERVICE_TYPE)],
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
