"""The per-client send queue's drop policy."""

from __future__ import annotations

import pytest

from bridge.effects import Send
from bridge.outgoing import ControlMessage
from bridge.sendqueue import SendQueue


def item(label: str, topic: str | None) -> Send:
    return Send(1, ControlMessage({"op": "x", "id": label}), topic)


def labels(queue: SendQueue) -> list[str]:
    out = []
    while (send := queue.pop()) is not None:
        out.append(send.item.payload["id"])
    return out


def test_drops_the_oldest_message_of_the_full_topic_only():
    queue = SendQueue(2)
    for label, topic in [("a1", "/a"), ("b1", "/b"), ("a2", "/a")]:
        assert queue.push(item(label, topic)) is None
    dropped = queue.push(item("a3", "/a"))
    assert dropped is not None and dropped.item.payload["id"] == "a1"
    assert labels(queue) == ["b1", "a2", "a3"]
    assert queue.dropped == {"/a": 1}


def test_many_busy_topics_do_not_push_each_other_out():
    queue = SendQueue(1)
    for n in range(50):
        assert queue.push(item(f"t{n}", f"/t{n}")) is None
    assert len(queue) == 50 and not queue.dropped


def test_responses_are_never_dropped_and_never_count():
    queue = SendQueue(1)
    queue.push(item("r1", None))
    queue.push(item("a1", "/a"))
    queue.push(item("r2", None))
    queue.push(item("a2", "/a"))
    assert labels(queue) == ["r1", "r2", "a2"]


def test_popping_frees_room_for_the_topic():
    queue = SendQueue(1)
    queue.push(item("a1", "/a"))
    assert queue.pop() is not None
    assert queue.push(item("a2", "/a")) is None
    assert queue.dropped == {}


def test_limit_must_be_positive():
    with pytest.raises(ValueError):
        SendQueue(0)
