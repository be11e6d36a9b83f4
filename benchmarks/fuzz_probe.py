"""Black-box probe of a bridge under hostile input: fuzz, poisoning, amplification, names, auth.

Starts `python -m bridge` as its own process (stderr to a file, so the log's size is what an
operator's disk sees) and then:

1. fuzz: `--connections` clients send `--frames` hostile frames in total
   (tests/bridge/hostile_frames.py) while a healthy publisher and subscriber exchange
   `/healthy` at `--rate` Hz beside them. Reports tracebacks and ERROR lines in the log, log
   bytes, the longest log line, close codes seen by the fuzzers (1011 = internal error), and
   the healthy subscriber's lost messages and latency p50/p99.
2. `--checks`: one client's odd names (lone surrogates) against `/rosapi/get_param_names`,
   `/rosapi/topics` and `GET /metrics` for another client; a provider's unencodable answer;
   amplification (`fragment_size: 1` with a long bad service name, a long id with
   `fragment_size: 1000`: bytes out per byte in); `/allowed/../denied` against
   `--topics-glob '/allowed/*'`; an `advertise_action` against `--services-glob`; the `auth`
   op.

Usage: python -m benchmarks.fuzz_probe [--frames 20000] [--connections 4] [--rate 100]
       [--checks] [--seed 0] [--bridge-root /work/main] [--keep-log FILE]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import multiprocessing
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from pathlib import Path

import websockets
from websockets.exceptions import ConnectionClosed

from tests.bridge.hostile_frames import HostileFrames
from tests.child_process import REPO_ROOT as ROOT

LISTENING = re.compile(r"listening on wss?://[^\s:]+:(\d+)")
HEALTHY_TOPIC = "/healthy"


@dataclass
class BridgeProcess:
    process: subprocess.Popen[bytes]
    log_path: Path
    port: int

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def log_text(self) -> str:
        return self.log_path.read_text("utf-8", errors="replace")


BRIDGE_ROOT = ROOT  # --bridge-root: probe another checkout's bridge (before/after figures)


@contextlib.contextmanager
def bridge_process(args: Sequence[str], workdir: Path) -> Iterator[BridgeProcess]:
    log_path = workdir / f"bridge-{time.monotonic_ns()}.log"
    env = {**os.environ, "PYTHONPATH": str(BRIDGE_ROOT)}
    with log_path.open("wb") as log:
        process = subprocess.Popen(
            [sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0", *args],
            cwd=BRIDGE_ROOT,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=log,
            stdin=subprocess.DEVNULL,
        )
    try:
        deadline = time.monotonic() + 120
        while not (match := LISTENING.search(log_path.read_text(errors="replace"))):
            if process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"bridge did not start:\n{log_path.read_text()}")
            time.sleep(0.1)
        yield BridgeProcess(process, log_path, int(match.group(1)))
    finally:
        process.terminate()
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(15)


# -- 1. fuzz beside a healthy client -----------------------------------------------------------


@dataclass
class FuzzResult:
    frames_sent: int = 0
    close_codes: Counter[int] = field(default_factory=Counter)
    published: int = 0
    lost: int = 0
    latencies_ms: list[float] = field(default_factory=list)


async def drain(ws: websockets.ClientConnection) -> None:
    with contextlib.suppress(ConnectionClosed):
        async for _ in ws:
            pass


async def fuzzer(url: str, frames: HostileFrames, budget: int, result: FuzzResult) -> None:
    sent = 0
    while sent < budget:
        async with websockets.connect(url, max_size=None, compression=None) as ws:
            reader = asyncio.create_task(drain(ws))
            try:
                while sent < budget:
                    await ws.send(next(frames))
                    sent += 1
                    result.frames_sent += 1
                    if sent % 50 == 0:
                        await asyncio.sleep(0)
            except ConnectionClosed:
                pass
            with contextlib.suppress(ConnectionClosed):
                await ws.close()
            await reader
            code = ws.close_code if ws.close_code is not None else -1
            if sent < budget or code not in (1000, 1005):
                result.close_codes[code] += 1


async def healthy_subscriber(
    url: str, result: HealthyResult, ready: asyncio.Event, done: asyncio.Event
) -> None:
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        await ws.send(
            json.dumps({"op": "subscribe", "topic": HEALTHY_TOPIC, "type": "std_msgs/msg/String"})
        )
        ready.set()
        while not done.is_set():
            try:
                frame = await asyncio.wait_for(ws.recv(), 0.5)
            except TimeoutError:
                continue
            message = json.loads(frame)
            if message.get("op") != "publish":
                continue
            seq, sent_ns = (int(x) for x in message["msg"]["data"].split())
            result.received.add(seq)
            result.latencies_ms.append((time.time_ns() - sent_ns) / 1e6)


async def healthy_publisher(
    url: str, rate_hz: float, result: HealthyResult, stop: asyncio.Event
) -> None:
    async with websockets.connect(url, max_size=None, compression=None) as ws:
        reader = asyncio.create_task(drain(ws))
        await ws.send(
            json.dumps({"op": "advertise", "topic": HEALTHY_TOPIC, "type": "std_msgs/msg/String"})
        )
        period_s, next_s = 1.0 / rate_hz, time.monotonic()
        while not stop.is_set():
            await ws.send(
                json.dumps(
                    {
                        "op": "publish",
                        "topic": HEALTHY_TOPIC,
                        "msg": {"data": f"{result.published} {time.time_ns()}"},
                    }
                )
            )
            result.published += 1
            next_s += period_s
            await asyncio.sleep(max(0.0, next_s - time.monotonic()))
        reader.cancel()


@dataclass
class HealthyResult:
    published: int = 0
    received: set[int] = field(default_factory=set)
    latencies_ms: list[float] = field(default_factory=list)


async def healthy_pair(url: str, rate_hz: float, control: Connection) -> HealthyResult:
    """Publish and receive `/healthy` until `control` says stop; runs in its own process so
    the fuzzers' CPU does not count as the bridge's latency."""
    result = HealthyResult()
    ready, stop, done = asyncio.Event(), asyncio.Event(), asyncio.Event()
    subscriber = asyncio.create_task(healthy_subscriber(url, result, ready, done))
    await ready.wait()
    publisher = asyncio.create_task(healthy_publisher(url, rate_hz, result, stop))
    await asyncio.sleep(0.5)
    control.send("ready")
    await asyncio.to_thread(control.recv)
    stop.set()
    await publisher
    deadline = time.monotonic() + 5
    while len(result.received) < result.published and time.monotonic() < deadline:
        await asyncio.sleep(0.1)
    done.set()
    await subscriber
    return result


def healthy_process(url: str, rate_hz: float, control: Connection) -> None:
    result = asyncio.run(healthy_pair(url, rate_hz, control))
    control.send((result.published, len(result.received), sorted(result.latencies_ms)))


async def fuzz(
    url: str, frames: int, connections: int, rate_hz: float, seed: int
) -> tuple[FuzzResult, float]:
    result = FuzzResult()
    control, child_end = multiprocessing.get_context("spawn").Pipe()
    healthy = multiprocessing.get_context("spawn").Process(
        target=healthy_process, args=(url, rate_hz, child_end), daemon=True
    )
    healthy.start()
    await asyncio.to_thread(control.recv)
    started = time.monotonic()
    await asyncio.gather(
        *(
            fuzzer(url, HostileFrames(seed + i), frames // connections, result)
            for i in range(connections)
        )
    )
    elapsed_s = time.monotonic() - started
    control.send("stop")
    result.published, received, result.latencies_ms = await asyncio.to_thread(control.recv)
    result.lost = result.published - received
    healthy.join(10)
    return result, elapsed_s


def log_figures(text: str) -> dict[str, object]:
    lines = text.splitlines()
    return {
        "log_bytes": len(text.encode("utf-8", errors="replace")),
        "log_lines": len(lines),
        "tracebacks": text.count("Traceback (most recent call last)"),
        "error_lines": sum(" ERROR " in line for line in lines),
        "longest_line": max((len(line) for line in lines), default=0),
    }


# -- 2. checks ---------------------------------------------------------------------------------


async def request(
    ws: websockets.ClientConnection, op: dict | str, answer_id: object, timeout_s: float = 3.0
) -> dict | None:
    """Send `op` and wait for the frame whose id is `answer_id` (None when none came)."""
    await ws.send(op if isinstance(op, str) else json.dumps(op))
    deadline = time.monotonic() + timeout_s
    while (left := deadline - time.monotonic()) > 0:
        try:
            message = json.loads(await asyncio.wait_for(ws.recv(), left))
        except (TimeoutError, ConnectionClosed):
            return None
        if message.get("id") == answer_id:
            return message
    return None


def http_status(port: int, path: str) -> int:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code


def healthy_drops(port: int) -> int | str:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=5) as response:
            text = response.read().decode()
    except urllib.error.HTTPError as exc:
        return f"? (GET /metrics answered {exc.code})"
    return sum(
        int(float(line.rsplit(" ", 1)[1]))
        for line in text.splitlines()
        if line.startswith("riverbridge_dropped_total") and HEALTHY_TOPIC in line
    )


async def poisoning(bridge: BridgeProcess) -> dict[str, object]:
    """One client's surrogate names against rosapi and /metrics for another client."""
    url, surrogate = bridge.url, '"\\ud800"'
    async with websockets.connect(url) as bad, websockets.connect(url) as good:
        await request(
            bad,
            '{"op":"call_service","service":"/rosapi/set_param","id":"p",'
            f'"args":{{"name":{surrogate},"value":"1"}}}}',
            "p",
        )
        await bad.send('{"op":"advertise","topic":"/poison\\ud800","type":"std_msgs/String"}')
        await bad.send('{"op":"advertise","topic":"/poison","type":"std_msgs/String"}')
        await bad.send('{"op":"subscribe","topic":"/poison","type":"std_msgs/String"}')
        await bad.send('{"op":"publish","topic":"/poison","msg":{"data":"\\ud800"}}')
        await asyncio.sleep(0.3)
        names = await request(
            good, {"op": "call_service", "service": "/rosapi/get_param_names", "id": "n"}, "n"
        )
        topics = await request(
            good, {"op": "call_service", "service": "/rosapi/topics", "id": "t"}, "t"
        )
        metrics = await asyncio.to_thread(http_status, bridge.port, "/metrics")
        # A provider answering with a lone surrogate: does its caller get an answer?
        await bad.send(
            json.dumps(
                {
                    "op": "advertise_service",
                    "service": "/poison_srv",
                    "type": "std_srvs/srv/Trigger",
                }
            )
        )
        await asyncio.sleep(0.2)
        await good.send(
            json.dumps({"op": "call_service", "service": "/poison_srv", "id": "c", "timeout": 10})
        )
        call = json.loads(await asyncio.wait_for(bad.recv(), 3))
        while call.get("op") != "call_service":
            call = json.loads(await asyncio.wait_for(bad.recv(), 3))
        await bad.send(
            '{"op":"service_response","service":"/poison_srv","id":'
            + json.dumps(call["id"])
            + ',"result":true,'
            '"values":{"success":true,"message":"\\ud800"}}'
        )
        answer = await request(
            good,
            json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "x"}),
            "c",
            3.0,
        )
    return {
        "get_param_names answered": names is not None,
        "topics answered": topics is not None,
        "GET /metrics": metrics,
        "provider's bad answer reaches caller": answer is not None
        and answer.get("result") is False,
    }


async def received_bytes(
    ws: websockets.ClientConnection, quiet_s: float = 1.0, limit_s: float = 20.0
) -> tuple[int, int]:
    """Bytes and frames received until the link is quiet for `quiet_s` (or `limit_s`)."""
    total = frames = 0
    deadline = time.monotonic() + limit_s
    while (left := deadline - time.monotonic()) > 0:
        try:  # the first frame may take long: a reply split in 1-character fragments
            frame = await asyncio.wait_for(ws.recv(), quiet_s if frames else left)
        except (TimeoutError, ConnectionClosed):
            break
        total += len(frame)
        frames += 1
    return total, frames


async def amplification(bridge: BridgeProcess, name_chars: int, id_chars: int) -> dict[str, object]:
    results: dict[str, object] = {}
    cases = {
        f"fragment_size 1, {name_chars // 1000} kB bad service name": {
            "op": "call_service",
            "service": "/" + "\u00e9" * name_chars,
            "id": "a",
            "fragment_size": 1,
        },
        f"fragment_size 1000, {id_chars // 1000} kB id": {
            "op": "call_service",
            "service": "/nope",
            "id": "i" * id_chars,
            "fragment_size": 1000,
        },
    }
    for label, op in cases.items():
        async with websockets.connect(bridge.url, max_size=None) as ws:
            text = json.dumps(op)
            await ws.send(text)
            out_bytes, out_frames = await received_bytes(ws)
            results[label] = (
                f"{out_frames} frames, {out_bytes:,} B out for "
                f"{len(text):,} B in ({out_bytes / len(text):.1f}x)"
            )
    return results


async def names_and_actions(workdir: Path) -> dict[str, object]:
    args = ["--topics-glob", "/allowed/*", "--services-glob", "/allowed/*"]
    with bridge_process(args, workdir) as bridge:
        async with websockets.connect(bridge.url) as ws:
            await ws.send(json.dumps({"op": "set_level", "level": "error"}))
            await ws.send(
                json.dumps(
                    {
                        "op": "advertise",
                        "topic": "/allowed/../denied",
                        "type": "std_msgs/String",
                        "id": "a",
                    }
                )
            )
            await ws.send(
                json.dumps(
                    {
                        "op": "advertise_action",
                        "action": "/denied_action",
                        "type": "example_interfaces/Fibonacci",
                        "id": "b",
                    }
                )
            )
            await asyncio.sleep(0.5)
            topics = await request(
                ws, {"op": "call_service", "service": "/rosapi/topics", "id": "t"}, "t"
            )
            actions = await request(
                ws, {"op": "call_service", "service": "/rosapi/action_servers", "id": "s"}, "s"
            )
    listed = topics["values"]["topics"] if topics else []
    return {
        "/allowed/../denied advertised": any(".." in t for t in listed),
        "/denied_action advertised": bool(actions and actions["values"]["action_servers"]),
    }


async def auth_op(bridge: BridgeProcess) -> dict[str, object]:
    async with websockets.connect(bridge.url) as ws:
        await ws.send(json.dumps({"op": "set_level", "level": "info"}))
        answer = await request(
            ws,
            {
                "op": "auth",
                "id": "auth",
                "mac": "0",
                "client": "c",
                "dest": "d",
                "rand": "r",
                "t": {"secs": 0, "nsecs": 0},
                "level": "admin",
                "end": {"secs": 0, "nsecs": 0},
            },
            "auth",
            2.0,
        )
    return {"auth op answered with": answer.get("msg") if answer else None}


# -- main --------------------------------------------------------------------------------------


async def run(args: argparse.Namespace, workdir: Path) -> None:
    with bridge_process([], workdir) as bridge:
        result, elapsed_s = await fuzz(
            bridge.url, args.frames, args.connections, args.rate, args.seed
        )
        figures = log_figures(bridge.log_text())
        if args.keep_log is not None:
            args.keep_log.write_text(bridge.log_text())
        lost = result.lost
        latencies = result.latencies_ms
        print(
            f"fuzz: {result.frames_sent:,} frames from {args.connections} connections in "
            f"{elapsed_s:.1f} s ({result.frames_sent / elapsed_s:,.0f} frames/s)"
        )
        for key, value in figures.items():
            print(f"  {key}: {value:,}")
        print(f"  close codes seen by fuzzers: {dict(result.close_codes)}")
        p99 = latencies[int(0.99 * (len(latencies) - 1))] if latencies else float("nan")
        print(
            f"  healthy client: {lost} of {result.published} lost; latency p50 "
            f"{statistics.median(latencies) if latencies else float('nan'):.1f} ms, "
            f"p99 {p99:.1f} ms"
        )
        print(
            f"  bridge alive: {bridge.process.poll() is None}; its /metrics counts "
            f"{healthy_drops(bridge.port)} drops on {HEALTHY_TOPIC}"
        )
        if args.checks:
            for label, check in [
                ("poisoning", poisoning(bridge)),
                ("amplification", amplification(bridge, 25_000, 100_000)),
                ("auth", auth_op(bridge)),
            ]:
                print(f"{label}:")
                for key, value in (await check).items():
                    print(f"  {key}: {value}")
    if args.checks:
        print("names and actions (--topics-glob/--services-glob '/allowed/*'):")
        for key, value in (await names_and_actions(workdir)).items():
            print(f"  {key}: {value}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=20_000)
    parser.add_argument("--connections", type=int, default=4)
    parser.add_argument("--rate", type=float, default=100.0, help="healthy messages per second")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--bridge-root",
        type=Path,
        default=ROOT,
        metavar="DIR",
        help="checkout whose bridge is probed (default: this one), e.g. "
        "/work/main for the figures before",
    )
    parser.add_argument(
        "--keep-log",
        type=Path,
        default=None,
        metavar="FILE",
        help="copy the fuzzed bridge's log here",
    )
    parser.add_argument(
        "--checks",
        action="store_true",
        help="also run the poisoning, amplification, names and auth checks",
    )
    args = parser.parse_args(argv)
    global BRIDGE_ROOT
    BRIDGE_ROOT = args.bridge_root.resolve()
    with tempfile.TemporaryDirectory(prefix="fuzz-probe-") as workdir:
        asyncio.run(run(args, Path(workdir)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
