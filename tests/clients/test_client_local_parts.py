"""Backoff, the subscription queue and the latest-only send slot, without a network."""

from __future__ import annotations

import asyncio
import itertools
import random

import numpy as np
import pytest
from pydantic import ValidationError

from clients.backoff import BackoffPolicy
from clients.errors import ClientClosed, ConnectionClosed
from clients.events import Received
from clients.publisher import TopicPublisher
from clients.subscription import Subscription, bytes_as_arrays
from clients.wire import Frame


def test_backoff_grows_to_the_cap_with_jitter_inside_bounds():
    policy = BackoffPolicy(initial_s=0.1, max_s=1.0, factor=2.0, jitter=0.5)
    delays = list(itertools.islice(policy.delays(random.Random(3)), 8))
    bases = [0.1, 0.2, 0.4, 0.8, 1.0, 1.0, 1.0, 1.0]
    for delay, base in zip(delays, bases, strict=True):
        assert base * 0.5 <= delay <= base
    assert len(set(delays)) == len(delays), "jitter must vary the delays"


def test_backoff_without_jitter_is_deterministic():
    policy = BackoffPolicy(initial_s=0.5, max_s=4.0, jitter=0.0)
    assert list(itertools.islice(policy.delays(random.Random()), 5)) == [0.5, 1, 2, 4, 4]


def test_backoff_rejects_initial_above_max():
    with pytest.raises(ValidationError):
        BackoffPolicy(initial_s=2.0, max_s=1.0)


async def _noop_unsubscribe(sub: Subscription) -> None:
    return None


def item(n: int) -> Received:
    return Received("/t", {"n": n}, recv_ns=n, wire_bytes=10)


def subscription(sub_id: str, maxsize: int, unsubscribe=_noop_unsubscribe) -> Subscription:
    """An untyped subscription of `/t` (messages as delivered, bytes as bytes)."""
    return Subscription(
        topic="/t",
        sub_id=sub_id,
        type=None,
        maxsize=maxsize,
        bytes_as_numpy=False,
        unsubscribe=unsubscribe,
    )


async def test_subscription_drops_oldest_and_counts():
    sub = subscription("subscribe:/t:1", 3)
    for n in range(10):
        sub.deliver(item(n))
    assert (sub.received, sub.dropped, sub.qsize()) == (10, 7, 3)
    assert [(await sub.get()).msg["n"] for _ in range(3)] == [7, 8, 9]


async def test_subscription_iteration_waits_then_ends_on_unsubscribe():
    calls = []

    async def record(sub: Subscription) -> None:
        calls.append(sub.id)

    sub = subscription("s1", 4, unsubscribe=record)

    async def consume() -> list[int]:
        return [r.msg["n"] async for r in sub]

    task = asyncio.create_task(consume())
    await asyncio.sleep(0)
    sub.deliver(item(1))
    sub.deliver(item(2))
    await asyncio.sleep(0)
    await sub.unsubscribe()
    await sub.unsubscribe()
    assert await asyncio.wait_for(task, 1) == [1, 2]
    assert calls == ["s1"]
    sub.deliver(item(3))
    assert sub.qsize() == 0


async def test_subscription_raises_connection_loss_after_draining():
    sub = subscription("s1", 4)
    sub.deliver(item(1))
    sub.finish(ConnectionClosed("gone"))
    assert (await sub.get()).msg["n"] == 1
    with pytest.raises(ConnectionClosed):
        await sub.get()
    sub2 = subscription("s2", 4)
    sub2.finish(ClientClosed("closed"))
    assert [r async for r in sub2] == []


def test_bytes_as_arrays_gives_zero_copy_views():
    data = bytes(range(32))
    msg = {"data": data, "header": {"frame_id": "x"}, "markers": [{"blob": b"\x01"}], "n": 3}
    out = bytes_as_arrays(msg)
    assert out["data"].dtype == np.uint8 and out["data"].shape == (32,)
    assert not out["data"].flags.writeable
    assert np.shares_memory(out["data"], np.frombuffer(data, np.uint8))
    assert out["markers"][0]["blob"].tolist() == [1]
    assert out["header"] == {"frame_id": "x"} and out["n"] == 3
    assert isinstance(msg["data"], bytes), "the original message is untouched"


class SlowLink:
    """A send callable that takes ``delay_s`` per frame and records what it sent."""

    def __init__(self, delay_s: float) -> None:
        self.delay_s = delay_s
        self.sent: list[bytes] = []

    async def send(self, frame: Frame) -> None:
        await asyncio.sleep(self.delay_s)
        self.sent.append(frame.data)


async def encode(topic: str, msg: dict) -> Frame:
    return Frame(str(msg["n"]).encode(), text=True)


async def test_latest_only_sends_newest_and_counts_stale():
    link = SlowLink(0.02)
    pub = TopicPublisher("/scan", latest_only=True, encode=encode, send=link.send)
    for n in range(10):
        await pub.publish({"n": n})
        await asyncio.sleep(0.004)
    await pub.flush()
    assert link.sent[0] == b"0" and link.sent[-1] == b"9"
    assert len(link.sent) < 10
    stats = pub.stats
    assert stats.sent == len(link.sent)
    assert stats.dropped_stale == 10 - len(link.sent)
    assert stats.wire_bytes == len(link.sent)


async def test_ordinary_topic_sends_everything_in_order():
    link = SlowLink(0.001)
    pub = TopicPublisher("/imu", latest_only=False, encode=encode, send=link.send)
    for n in range(5):
        await pub.publish({"n": n})
    assert link.sent == [b"0", b"1", b"2", b"3", b"4"]
    assert pub.stats.dropped_stale == 0


async def test_latest_only_counts_sends_lost_to_a_closed_link():
    async def closed(frame: Frame) -> None:
        raise ConnectionClosed("down")

    pub = TopicPublisher("/scan", latest_only=True, encode=encode, send=closed)
    await pub.publish({"n": 1})
    await pub.flush()
    assert pub.stats.dropped_disconnected == 1 and pub.stats.sent == 0


def test_binary_fragments_interleaved_with_others_join_into_the_cbor_frame():
    """riverbridge's CBOR fragments (docs/bridge.md, "Over a thin link"): byte slices of one
    CBOR frame, pieces of two messages interleaved, joined per id."""
    from clients.fragments import FragmentAssembler
    from schemas.ops import Fragment

    assembler = FragmentAssembler()
    first, second = b"\xa1\x61a\x01" * 3, b"\xa1\x61b\x02" * 2
    pieces = [("f:1", first[:5], 0, 3), ("f:2", second[:4], 0, 2), ("f:1", first[5:10], 1, 3)]
    for key, data, num, total in pieces:
        assert assembler.add(Fragment(id=key, data=data, num=num, total=total), 10) is None
    done = assembler.add(Fragment(id="f:2", data=second[4:], num=1, total=2), 10)
    assert done is not None and done.text == second
    done = assembler.add(Fragment(id="f:1", data=first[10:], num=2, total=3), 10)
    assert done is not None and done.text == first and done.wire_bytes == 30
