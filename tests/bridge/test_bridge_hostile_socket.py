"""A real bridge process under 10,000 hostile frames, with a healthy client beside them.

The bridge runs as `python -m bridge` (its log is what an operator's disk receives); four
connections send frames from `hostile_frames.HostileFrames` as fast as the bridge reads them
while a publisher and a subscriber exchange `/healthy` at 100 Hz. Nothing may crash or close
with 1011, the log stays small and free of tracebacks, and the healthy subscriber loses
nothing. benchmarks/fuzz_probe.py is the same probe with figures.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import re
import sys
import time
import urllib.request

import pytest
import websockets
from websockets.exceptions import ConnectionClosed

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from tests.bridge.hostile_frames import HostileFrames
from tests.child_process import running

pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]

FUZZ_CONNECTIONS = 4
FRAMES_PER_CONNECTION = 2_500  # 10,000 in all
HEALTHY_TOPIC = "/healthy"
HEALTHY_PERIOD_S = 0.01


async def drain(ws: websockets.ClientConnection) -> None:
    with contextlib.suppress(ConnectionClosed):
        async for _ in ws:
            pass


async def fuzz(url: str, seed: int, close_codes: list[int | None]) -> None:
    frames = HostileFrames(seed)
    batch = [next(frames) for _ in range(FRAMES_PER_CONNECTION)]
    sent = 0
    while sent < len(batch):
        async with websockets.connect(url, max_size=None) as ws:
            reader = asyncio.create_task(drain(ws))
            with contextlib.suppress(ConnectionClosed):
                for frame in batch[sent:]:
                    await ws.send(frame)
                    sent += 1
            if sent < len(batch):
                close_codes.append(ws.close_code)
            await ws.close()
            await reader


async def healthy(url: str, stop: asyncio.Event) -> tuple[int, set[int]]:
    """Publish a sequence on /healthy until `stop`, then return (published, received)."""
    received: set[int] = set()
    async with websockets.connect(url) as sub, websockets.connect(url) as pub:
        await sub.send(
            json.dumps({"op": "subscribe", "topic": HEALTHY_TOPIC, "type": "std_msgs/msg/Int64"})
        )
        await pub.send(
            json.dumps({"op": "advertise", "topic": HEALTHY_TOPIC, "type": "std_msgs/msg/Int64"})
        )
        await asyncio.sleep(0.3)

        async def listen() -> None:
            async for frame in sub:
                received.add(json.loads(frame)["msg"]["data"])

        listener = asyncio.create_task(listen())
        published = 0
        while not stop.is_set():
            await pub.send(
                json.dumps({"op": "publish", "topic": HEALTHY_TOPIC, "msg": {"data": published}})
            )
            published += 1
            await asyncio.sleep(HEALTHY_PERIOD_S)
        deadline = time.monotonic() + 10
        while len(received) < published and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        listener.cancel()
    return published, received


async def run_fuzz(url: str) -> tuple[int, set[int], list[int | None]]:
    stop, close_codes = asyncio.Event(), []
    healthy_task = asyncio.create_task(healthy(url, stop))
    await asyncio.sleep(0.5)
    await asyncio.gather(*(fuzz(url, seed, close_codes) for seed in range(FUZZ_CONNECTIONS)))
    stop.set()
    published, received = await healthy_task
    return published, received, close_codes


def test_ten_thousand_hostile_frames_break_nothing_and_lose_nothing():
    with running([sys.executable, "-m", "bridge", "--port", "0"]) as bridge:
        match = bridge.wait_for_line(r"listening on ws://127\.0\.0\.1:(\d+)")
        port = int(match.group(1))
        published, received, close_codes = asyncio.run(run_fuzz(f"ws://127.0.0.1:{port}"))
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10) as page:
            assert page.status == 200
        log = bridge.text()
    assert published > 50 and received == set(range(published)), (
        f"healthy subscriber lost {published - len(received)} of {published}"
    )
    assert all(code == 1009 for code in close_codes), close_codes  # fragment limit only
    assert "Traceback" not in log
    error_lines = [line for line in log.splitlines() if " ERROR " in line]
    summaries = re.findall(r"bad frames in the last", log)
    # Each fuzzing connection: at most 20 lines per 10 s window, then one summary.
    assert len(error_lines) <= 20 * FUZZ_CONNECTIONS * 2 and len(summaries) >= 1
    assert len(log) < 200_000 and max(len(line) for line in log.splitlines()) < 700


async def answer(ws: websockets.ClientConnection, op: dict | str, answer_id: object) -> dict:
    await ws.send(op if isinstance(op, str) else json.dumps(op))
    while True:
        message = json.loads(await asyncio.wait_for(ws.recv(), 10))
        if message.get("id") == answer_id:
            return message


async def received_bytes(ws: websockets.ClientConnection) -> tuple[int, int]:
    """Frames and bytes that arrive until the link has been quiet for half a second."""
    frames = total = 0
    with contextlib.suppress(TimeoutError):
        while True:
            total += len(await asyncio.wait_for(ws.recv(), 0.5))
            frames += 1
    return frames, total


@pytest.mark.timeout(60)
async def test_one_clients_odd_names_break_nothing_for_others(registry):
    async with run_bridge(BridgeConfig(port=0), registry) as bridge:
        url = bridge.url
        async with websockets.connect(url) as bad, websockets.connect(url) as good:
            await bad.send(
                '{"op":"call_service","service":"/rosapi/set_param","id":"p",'
                '"args":{"name":"\\ud800","value":"1"}}'
            )
            await bad.send('{"op":"advertise","topic":"/poison\\ud800","type":"std_msgs/String"}')
            await bad.send('{"op":"advertise_service","service":"/p","type":"std_srvs/Trigger"}')
            names = await answer(
                good, {"op": "call_service", "id": "n", "service": "/rosapi/get_param_names"}, "n"
            )
            topics = await answer(
                good, {"op": "call_service", "id": "t", "service": "/rosapi/topics"}, "t"
            )
            assert names["result"] and topics["result"]
            page = await asyncio.to_thread(
                urllib.request.urlopen, f"http://127.0.0.1:{bridge.port}/metrics", timeout=10
            )
            assert page.status == 200
            await good.send(json.dumps({"op": "call_service", "service": "/p", "id": "c"}))
            request = json.loads(await asyncio.wait_for(bad.recv(), 10))
            while request.get("op") != "call_service":
                request = json.loads(await asyncio.wait_for(bad.recv(), 10))
            await bad.send(
                '{"op":"service_response","service":"/p","result":true,"id":'
                + json.dumps(request["id"])
                + ',"values":{"message":"\\ud800"}}'
            )
            failed = json.loads(await asyncio.wait_for(good.recv(), 10))
            assert (failed["id"], failed["result"]) == ("c", False)


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    ("op", "bytes_in"),
    [
        (
            {"op": "call_service", "service": "/" + "é" * 250_000, "id": "a", "fragment_size": 1},
            250_000,
        ),
        (
            {
                "op": "call_service",
                "service": "/nope",
                "id": "i" * 1_000_000,
                "fragment_size": 1000,
            },
            1_000_000,
        ),
    ],
)
async def test_replies_are_never_much_larger_than_their_request(registry, op, bytes_in):
    async with (
        run_bridge(BridgeConfig(port=0), registry) as bridge,
        websockets.connect(bridge.url, max_size=None) as ws,
    ):
        await ws.send(json.dumps(op))
        frames, bytes_out = await received_bytes(ws)
    assert 1 <= frames <= 10 and bytes_out < 10_000 < bytes_in


@pytest.mark.timeout(60)
async def test_a_client_that_asks_without_reading_is_closed_past_its_reply_budget(registry, caplog):
    """90-byte questions with ~100 kB answers, never read: closed at the budget (1008)."""
    config = BridgeConfig(port=0, reply_budget_bytes=2 * 1024 * 1024)
    async with run_bridge(config, registry) as bridge, websockets.connect(bridge.url) as good:
        async with websockets.connect(bridge.url, max_queue=1) as greedy:
            for index in range(40):  # every full definition makes the answer larger
                await greedy.send(
                    json.dumps(
                        {
                            "op": "advertise",
                            "topic": f"/m{index}",
                            "type": "visualization_msgs/msg/MarkerArray",
                        }
                    )
                )
            question = json.dumps(
                {"op": "call_service", "id": "q", "service": "/rosapi/topics_and_raw_types"}
            )
            with contextlib.suppress(ConnectionClosed):
                for _ in range(2000):
                    await greedy.send(question)
                    if len(bridge.server.links) < 2:
                        break
            deadline = time.monotonic() + 20
            while len(bridge.server.links) > 1:
                assert time.monotonic() < deadline, "the greedy client is still connected"
                await asyncio.sleep(0.05)
        assert "MiB of replies unread (limit 2 MiB)" in caplog.text
        reply = await answer(
            good, {"op": "call_service", "id": "g", "service": "/rosapi/get_time"}, "g"
        )
        assert reply["result"] is True
