"""Inbound fragment reassembly and expiry in the core."""

from __future__ import annotations

import json


def pieces(text: str, size: int, frag_id: str = "f1", float_total: bool = False) -> list[dict]:
    chunks = [text[i : i + size] for i in range(0, len(text), size)]
    total = (len(text) - 1) / size + 1 if float_total else len(chunks)
    return [
        {"op": "fragment", "id": frag_id, "num": i, "total": total, "data": chunk}
        for i, chunk in enumerate(chunks)
    ]


def test_out_of_order_fragments_with_float_total_form_any_op(harness):
    caller = harness.connect()
    call = json.dumps({"op": "call_service", "service": "/rosapi/get_ros_version", "id": "v"})
    fragments = pieces(call, 8, float_total=True)
    assert not float(fragments[0]["total"]).is_integer()
    for fragment in reversed(fragments):
        harness.send(caller, fragment)
    response = harness.outbox(caller)
    assert response == [
        {
            "op": "service_response",
            "service": "/rosapi/get_ros_version",
            "values": {"version": 2, "distro": "jazzy"},
            "result": True,
            "id": "v",
        }
    ]
    assert harness.state.sessions[caller].fragments == {}


def test_incomplete_fragments_expire(registry):
    from tests.bridge.bridge_harness import CoreHarness

    harness = CoreHarness(registry, fragment_timeout_s=2.0)
    caller = harness.connect()
    call = json.dumps({"op": "call_service", "service": "/rosapi/nodes", "id": "n"})
    first, *rest = pieces(call, 8)
    harness.send(caller, first)
    harness.advance(3.0)
    assert harness.state.sessions[caller].fragments == {}
    for fragment in rest:
        harness.send(caller, fragment)
    assert harness.outbox(caller) == []
    assert len(harness.state.sessions[caller].fragments) == 1


def test_fragments_with_conflicting_totals_or_bad_numbers_are_refused(harness):
    client = harness.connect()
    harness.send(client, {"op": "fragment", "id": "a", "num": 0, "total": 2, "data": "{"})
    harness.send(client, {"op": "fragment", "id": "a", "num": 1, "total": 3, "data": "}"})
    harness.send(client, {"op": "fragment", "id": "a", "num": 5, "total": 2, "data": "}"})
    assert harness.state.sessions[client].fragments["a"].pieces == {0: "{"}


def test_fragments_beyond_the_size_limit_close_the_client_with_1009(registry):
    from tests.bridge.bridge_harness import CoreHarness

    harness = CoreHarness(registry, max_message_size=100)
    client, other = harness.connect(), harness.connect()
    for frag_id in ("a", "b"):
        harness.send(
            client, {"op": "fragment", "id": frag_id, "num": 0, "total": 10, "data": "x" * 40}
        )
    harness.send(other, {"op": "fragment", "id": "a", "num": 0, "total": 10, "data": "y" * 40})
    assert harness.closes == []
    harness.send(client, {"op": "fragment", "id": "c", "num": 0, "total": 10, "data": "x" * 40})
    assert [(c.client_id, c.code) for c in harness.closes] == [(client, 1009)]
    assert harness.state.sessions[client].fragments == {}
    assert len(harness.state.sessions[other].fragments) == 1


def test_disconnect_drops_fragment_buffers(harness):
    client = harness.connect()
    harness.send(client, {"op": "fragment", "id": "a", "num": 0, "total": 2, "data": "{"})
    harness.disconnect(client)
    assert harness.state.sessions == {}
    harness.advance(1000.0)


def test_reassembled_garbage_is_logged_not_fatal(harness):
    client = harness.connect()
    harness.send(client, {"op": "fragment", "id": 7, "num": 0, "total": 2, "data": "{nope"})
    harness.send(client, {"op": "fragment", "id": 7, "num": 1, "total": 2, "data": "!!"})
    harness.send(client, {"op": "call_service", "service": "/rosapi/nodes", "id": 1})
    assert harness.outbox(client)[0]["result"] is True


def test_binary_fragments_from_a_client_are_refused_with_a_clear_line(harness, caplog):
    """The bridge sends CBOR fragments on request; it takes only text ones (a JSON op)."""
    from schemas import codec_cbor

    caller = harness.connect()
    fragment = {"op": "fragment", "id": "b", "num": 0, "total": 2, "data": b"\xa1"}
    harness.send(caller, codec_cbor.dumps(fragment))
    assert harness.state.sessions[caller].fragments == {}
    assert "fragment data must be text" in caplog.text
