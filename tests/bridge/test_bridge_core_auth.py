"""rosauth's `auth` op in the sans-I/O core: nothing before it, a failed one closes."""

from __future__ import annotations

import pytest

from schemas import rosauth
from tests.bridge.bridge_harness import START_NS, CoreHarness

SECRET = "1234567890abcdef"  # rosauth's secrets are 16 characters
NOW_S = START_NS // 1_000_000_000


@pytest.fixture
def secured(registry) -> CoreHarness:
    return CoreHarness(registry, auth_secret=SECRET)


def signed(**changes) -> dict:
    op = rosauth.auth_op(SECRET, NOW_S, client="192.168.1.101", dest="192.168.1.111", level="admin")
    return {**op, **changes}


def test_ops_before_auth_are_refused_and_calls_answered(secured):
    client = secured.connect()
    secured.send(client, {"op": "subscribe", "topic": "/a", "type": "std_msgs/String"})
    assert secured.state.topic_subscriptions == {}
    reply = secured.call(client, "/rosapi/topics")
    assert reply["result"] is False and "not authenticated" in reply["values"]
    assert secured.closes == []


def test_a_valid_auth_opens_the_bridge(secured):
    client = secured.connect()
    secured.send(client, signed())
    assert secured.call(client, "/rosapi/get_time")["result"] is True
    assert secured.closes == []


@pytest.mark.parametrize(
    ("changes", "why"),
    [
        ({"mac": "0" * 128}, "mac does not match"),
        ({"level": "user"}, "mac does not match"),  # any field changed breaks the MAC
        ({"t": NOW_S - 6}, "from the bridge's clock"),
        ({"t": NOW_S + 6}, "from the bridge's clock"),
        ({"end": NOW_S - 1}, "not in the future"),
        ({"t": "yesterday"}, "must be times"),
    ],
)
def test_a_failed_auth_closes_the_connection(secured, caplog, changes, why):
    client = secured.connect()
    secured.send(client, signed(**changes))
    [close] = secured.closes
    assert (close.client_id, close.code, close.reason) == (client, 1008, "authentication failed")
    assert why in caplog.text
    secured.send(client, {"op": "call_service", "service": "/rosapi/topics", "id": 1})
    assert secured.outbox(client) == []  # nothing more is handled on a closing connection


def test_times_may_be_ros_time_objects(secured):
    op = signed()
    t, end = op["t"], op["end"]
    client = secured.connect()
    secured.send(client, {**op, "t": {"secs": t, "nsecs": 5}, "end": {"sec": end, "nanosec": 0}})
    assert secured.call(client, "/rosapi/get_time")["result"] is True


def test_other_clients_are_unaffected_by_one_failing(secured):
    good, bad = secured.connect(), secured.connect()
    secured.send(good, signed())
    secured.send(bad, signed(mac="00"))
    assert [c.client_id for c in secured.closes] == [bad]
    assert secured.call(good, "/rosapi/get_time")["result"] is True


def test_without_a_secret_auth_is_ignored(harness):
    client = harness.connect()
    harness.send(client, signed(mac="00"))
    assert harness.closes == []
    assert harness.call(client, "/rosapi/get_time")["result"] is True
