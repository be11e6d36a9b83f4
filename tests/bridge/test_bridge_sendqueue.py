"""The per-client backlog: bounded in bytes, drop-oldest per topic, answers never dropped."""

from __future__ import annotations

import pytest

from bridge.effects import Send
from bridge.outgoing import ControlMessage
from bridge.sendqueue import SendQueue


def item(label: str, topic: str | None) -> Send:
    return Send(1, ControlMessage({"op": "x", "id": label}), topic)


def labels(queue: SendQueue, busy: tuple[str | None, ...] = ()) -> list[str]:
    out = []
    while (waiting := queue.pop(busy)) is not None:
        out.append(waiting.send.item.payload["id"])
    return out


def test_nothing_is_dropped_within_the_bound():
    queue = SendQueue(1000)
    for n in range(10):
        assert queue.push(item(f"a{n}", "/a"), 100) == []
    assert len(queue) == 10 and queue.bytes == 1000 and not queue.dropped


def test_past_the_bound_the_pushed_topic_loses_its_oldest():
    queue = SendQueue(300)
    for label, topic in [("a1", "/a"), ("b1", "/b"), ("a2", "/a")]:
        assert queue.push(item(label, topic), 100) == []
    dropped = queue.push(item("a3", "/a"), 100)
    assert [d.item.payload["id"] for d in dropped] == ["a1"]
    assert labels(queue) == ["b1", "a2", "a3"]
    assert queue.dropped == {"/a": 1}


def test_bytes_already_in_the_transport_count_against_the_bound():
    queue = SendQueue(1000)
    queue.push(item("a1", "/a"), 100)
    dropped = queue.push(item("a2", "/a"), 100, outside_bytes=850)
    assert [d.item.payload["id"] for d in dropped] == ["a1"]


def test_a_topic_keeps_its_newest_message_and_never_evicts_another_topic():
    queue = SendQueue(100)
    for n in range(50):
        assert queue.push(item(f"t{n}", f"/t{n}"), 100) == []
    assert len(queue) == 50 and not queue.dropped


def test_answers_are_never_dropped_and_never_push_out_a_message():
    queue = SendQueue(200)
    queue.push(item("r1", None), 100)
    queue.push(item("a1", "/a"), 100)
    queue.push(item("r2", None), 100)
    assert queue.answers_waiting == 2
    queue.push(item("a2", "/a"), 100)
    assert labels(queue) == ["r1", "r2", "a2"]
    assert queue.answers_waiting == 0 and queue.bytes == 0


def test_a_busy_stream_is_skipped_and_keeps_its_place():
    queue = SendQueue(1000)
    for label, topic in [
        ("scan1", "/scan"),
        ("imu1", "/imu"),
        ("scan2", "/scan"),
        ("imu2", "/imu"),
    ]:
        queue.push(item(label, topic), 10)
    assert labels(queue, busy=("/scan",)) == ["imu1", "imu2"]
    first = queue.pop()
    assert first is not None and first.send.item.payload["id"] == "scan1"
    queue.push_front(first)
    assert labels(queue) == ["scan1", "scan2"]


def test_limit_must_be_positive():
    with pytest.raises(ValueError):
        SendQueue(0)


# -- freshness (docs/bridge.md, "Over a thin link") ------------------------------------------


def kept(label: str, topic: str, keep: int) -> Send:
    return Send(1, ControlMessage({"op": "x", "id": label}), topic, keep=keep)


def test_queue_length_keeps_only_the_newest_waiting_counted_as_conflated():
    queue = SendQueue(10_000)
    assert queue.push(kept("a1", "/a", 1), 100) == []
    dropped = queue.push(kept("a2", "/a", 1), 100)
    assert [d.item.payload["id"] for d in dropped] == ["a1"]
    queue.push(kept("b1", "/b", 2), 100)
    queue.push(kept("b2", "/b", 2), 100)
    queue.push(kept("b3", "/b", 2), 100)
    assert labels(queue) == ["a2", "b2", "b3"]
    assert queue.conflated == {"/a": 1, "/b": 1} and not queue.dropped


def test_a_partly_sent_message_is_never_conflated_and_its_rest_goes_last_in_line():
    queue = SendQueue(10_000)
    queue.push(kept("scan1", "/scan", 1), 3000)
    scan = queue.pop()
    assert scan is not None
    queue.push(item("imu1", "/imu"), 100)
    queue.requeue(scan, 1000)  # one fragment left; the IMU sample queued meanwhile goes first
    queue.push(kept("scan2", "/scan", 1), 3000)  # waits behind scan1's rest, drops nothing
    queue.push(kept("scan3", "/scan", 1), 3000)  # replaces scan2, never scan1's rest
    assert queue.conflated == {"/scan": 1}
    assert labels(queue) == ["imu1", "scan1", "scan3"]


def test_small_items_go_before_large_ones_and_each_stream_keeps_its_order():
    queue = SendQueue(10_000_000)
    queue.push(item("big1", "/scan"), 500_000)
    queue.push(item("imu1", "/imu"), 200)
    queue.push(item("big2", "/scan"), 500_000)
    queue.push(item("answer", None), 300)
    queue.push(item("imu2", "/imu"), 200)
    assert labels(queue) == ["imu1", "answer", "imu2", "big1", "big2"]


def test_only_lossless_items_count_towards_pacing_publishers():
    queue = SendQueue(10_000)
    queue.push(kept("scan", "/scan", 1), 3000)
    queue.push(item("imu", "/imu"), 100)
    assert queue.bytes == 3100 and queue.lossless_bytes == 100
    queue.pop()
    queue.pop()
    assert queue.bytes == queue.lossless_bytes == 0
