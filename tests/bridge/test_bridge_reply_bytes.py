# ruff: noqa: E501  (pinned frames are written out whole, one per line)
"""The exact bytes of everything the bridge sends, pinned.

Key order, spelling, an absent `id`, base64, `null` for NaN and the CBOR tags are what
roslibpy, roslibjs, Foxglove and captured traffic see. Building replies from `schemas.ops`
models must not move a byte of them: each scenario drives the sans-I/O core through
`CoreHarness` and compares the rendered frames with the bytes the bridge sent before.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable

import pytest

from schemas.registry import TypeRegistry
from tests.bridge.bridge_harness import CoreHarness

FIB = "example_interfaces/action/Fibonacci"


def frames_of(h: CoreHarness, client: int) -> list[bytes]:
    """Rendered frames for `client`; a binary frame is written as ``b"cbor:" + hex``."""
    return [f.data if f.text else b"cbor:" + f.data.hex().encode() for f in h.frames(client)]


def provider_and_caller(h: CoreHarness) -> tuple[int, int]:
    provider, caller = h.connect(), h.connect()
    h.send(provider, {"op": "advertise_service", "service": "/set", "type": "std_srvs/SetBool"})
    h.send(provider, {"op": "advertise_action", "action": "/fib", "type": FIB})
    return provider, caller


def service_round_trip(h: CoreHarness) -> list[bytes]:
    provider, caller = provider_and_caller(h)
    h.send(caller, {"op": "call_service", "service": "set", "id": "c1", "args": [True]})
    h.send(caller, {"op": "call_service", "service": "/set#s2", "args": {}})
    h.send(caller, {"op": "call_service", "service": "/set", "id": 7})
    out = frames_of(h, provider)
    for request_id, values in [
        ("service_request:/set:1", {"success": True, "message": 'q"\u00e9'}),
        ("service_request:/set:2", "provider says no"),
    ]:
        h.send(
            provider,
            {
                "op": "service_response",
                "service": "/set",
                "id": request_id,
                "values": values,
                "result": not isinstance(values, str),
                "extra": 1,
            },
        )
    h.send(provider, {"op": "service_response", "id": "service_request:/set:3", "values": {}})
    return out + frames_of(h, caller)


def service_failures(h: CoreHarness) -> list[bytes]:
    caller = h.connect()
    h.send(caller, {"op": "call_service", "service": "/nowhere", "id": "n1"})
    h.send(caller, {"op": "call_service", "service": "/nowhere"})
    h.send(caller, {"op": "call_service", "service": "/nowhere", "id": 1.5, "args": 3})
    h.send(caller, {"op": "call_service", "service": "/x", "id": "bad", "timeout": "soon"})
    provider = h.connect()
    h.send(provider, {"op": "advertise_service", "service": "/slow", "type": "pkg/Unknown"})
    h.send(caller, {"op": "call_service", "service": "/slow", "id": "t", "timeout": 0.5})
    h.advance(1.0)
    h.send(caller, {"op": "call_service", "service": "/slow", "id": "gone"})
    h.disconnect(provider)
    return frames_of(h, caller)


def rosapi_answers(h: CoreHarness) -> list[bytes]:
    client = h.connect()
    h.send(client, {"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
    for service, args in [
        ("/rosapi/topics", None),
        ("rosapi/topic_type", {"topic": "/chatter"}),
        ("/rosapi/get_time", {}),
        ("/rosapi/set_param", {"name": "/p", "value": "[1, 2]"}),
        ("/rosapi/get_param", {"name": "/p"}),
        ("/rosapi/get_param", {"name": 3}),
        ("/rosapi/message_details", {"type": "std_msgs/msg/String"}),
    ]:
        op = {"op": "call_service", "service": service, "id": service}
        if args is not None:
            op["args"] = args
        h.send(client, op)
    return frames_of(h, client)


def status_answers(h: CoreHarness) -> list[bytes]:
    client = h.connect()
    h.send(client, {"op": "bogus", "id": "quiet"})  # no status before set_level
    h.send(client, {"op": "set_level", "level": "info", "id": "lvl"})
    h.send(client, {"op": "bogus", "id": "b1"})
    h.send(client, {"op": "subscribe", "topic": "/t", "throttle_rate": "fast"})
    h.send(
        client,
        {
            "op": "auth",
            "mac": "m",
            "client": "c",
            "dest": "d",
            "rand": "r",
            "t": 0,
            "level": "user",
            "end": 0,
            "id": 5,
        },
    )
    h.send(client, '{"op":"publish","topic":"/t","msg":{}}')
    h.send(client, b"\xff\x00")
    return frames_of(h, client)


def action_flow(h: CoreHarness) -> list[bytes]:
    provider, caller = provider_and_caller(h)
    goal = {"op": "send_action_goal", "action": "fib", "action_type": FIB, "args": [3]}
    h.send(caller, {**goal, "id": "g1", "feedback": True})
    h.send(caller, {**goal, "id": "g2"})
    h.send(caller, {**goal, "feedback": True})
    out = frames_of(h, provider)
    h.send(
        provider,
        {
            "op": "action_feedback",
            "id": "action_goal:/fib:1",
            "action": "/fib",
            "values": {"sequence": [0, 1]},
        },
    )
    h.send(
        provider,
        {
            "op": "action_feedback",
            "id": "action_goal:/fib:3",
            "action": "/fib",
            "values": {"sequence": [0]},
        },
    )
    h.send(
        provider,
        {
            "op": "action_result",
            "id": "action_goal:/fib:1",
            "action": "/fib",
            "values": {"sequence": [0, 1, 1]},
            "status": 4,
            "result": True,
        },
    )
    h.send(
        provider,
        {
            "op": "action_result",
            "id": "action_goal:/fib:2",
            "action": "/fib",
            "values": "gave up",
            "status": 6,
            "result": False,
        },
    )
    h.send(caller, {"op": "cancel_action_goal", "action": "/fib", "id": None})
    out += frames_of(h, caller) + frames_of(h, provider)
    h.send(caller, {**goal, "id": "g4"})
    h.send(caller, {"op": "cancel_action_goal", "action": "/fib", "id": "g4"})
    h.send(caller, {"op": "send_action_goal", "action": "/none", "action_type": FIB, "id": 9})
    h.send(caller, {"op": "send_action_goal", "action": "/fib", "id": "no type"})
    out += frames_of(h, caller) + frames_of(h, provider)
    h.disconnect(caller)
    h.send(provider, {"op": "unadvertise_action", "action": "/fib"})
    return out + frames_of(h, provider)


def publish_encodings(h: CoreHarness) -> list[bytes]:
    publisher, subscriber = h.connect(), h.connect()
    h.send(publisher, {"op": "advertise", "topic": "/img", "type": "sensor_msgs/CompressedImage"})
    h.send(publisher, {"op": "advertise", "topic": "/f", "type": "std_msgs/Float64MultiArray"})
    for n, compression in enumerate(["none", "cbor", "cbor-raw", "png", "zip"]):
        for topic in ("/img", "f"):
            h.send(
                subscriber,
                {"op": "subscribe", "topic": topic, "id": n, "compression": compression},
            )
        h.send(
            publisher,
            {
                "op": "publish",
                "topic": "/img",
                "msg": {
                    "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "cam"},
                    "format": "jpeg",
                    "data": "AAEC/w==",
                },
            },
        )
        h.send(
            publisher,
            {"op": "publish", "topic": "/f", "msg": {"data": [1.5, float("nan"), -0.0, 1e300]}},
        )
        for topic in ("/img", "f"):
            h.send(subscriber, {"op": "unsubscribe", "topic": topic})
    return frames_of(h, subscriber)


def fragments(h: CoreHarness) -> list[bytes]:
    provider, caller = provider_and_caller(h)
    subscriber = h.connect()
    h.send(provider, {"op": "advertise", "topic": "/s", "type": "std_msgs/String"})
    h.send(subscriber, {"op": "subscribe", "topic": "/s", "fragment_size": 1000})
    text = "".join(chr(32 + i % 95) for i in range(2100))
    h.send(provider, {"op": "publish", "topic": "/s", "msg": {"data": text}})
    h.send(caller, {"op": "call_service", "service": "/set", "id": 2.5, "fragment_size": 1})
    h.send(caller, {"op": "call_service", "service": "/set", "id": "long"})
    long_message = "\u00e9" * 400 + "x" * 700
    for n in (1, 2):
        h.send(
            provider,
            {
                "op": "service_response",
                "service": "/set",
                "id": f"service_request:/set:{n}",
                "values": {"success": True, "message": long_message},
                "result": True,
            },
        )
    return frames_of(h, subscriber) + frames_of(h, caller)


SCENARIOS: dict[str, Callable[[CoreHarness], list[bytes]]] = {
    "service_round_trip": service_round_trip,
    "service_failures": service_failures,
    "rosapi_answers": rosapi_answers,
    "status_answers": status_answers,
    "action_flow": action_flow,
    "publish_encodings": publish_encodings,
    "fragments": fragments,
}

#: Scenario -> the frames it produced before replies were built from models (short ones
#: written out; long ones by count and SHA-256 of the frames joined with a newline).
EXPECTED: dict[str, list[bytes] | tuple[int, str]] = {
    "service_round_trip": [
        b'{"op":"call_service","id":"service_request:/set:1","service":"/set","args":{"data":true}}',
        b'{"op":"call_service","id":"service_request:/set:2","service":"/set","args":{"data":false}}',
        b'{"op":"call_service","id":"service_request:/set:3","service":"/set","args":{"data":false}}',
        b'{"op":"service_response","service":"set","values":{"success":true,"message":"q\\"\\u00e9"},"result":true,"id":"c1"}',
        b'{"op":"service_response","service":"/set#s2","values":"provider says no","result":false,"id":"s2"}',
        b'{"op":"service_response","service":"/set","values":{"success":false,"message":""},"result":true,"id":7}',
    ],
    "service_failures": [
        b'{"op":"service_response","service":"/nowhere","values":"Service /nowhere does not exist","result":false,"id":"n1"}',
        b'{"op":"service_response","service":"/nowhere","values":"Service /nowhere does not exist","result":false}',
        b'{"op":"service_response","service":"/nowhere","values":"Service /nowhere does not exist","result":false,"id":1.5}',
        b'{"op":"service_response","service":"/x","values":"malformed op: call_service: field \'timeout\' must be a number, got \'soon\'","result":false,"id":"bad"}',
        b'{"op":"service_response","service":"/slow","values":"Service /slow call timed out after 0.5 s","result":false,"id":"t"}',
        b'{"op":"service_response","service":"/slow","values":"Service /slow provider disconnected","result":false,"id":"gone"}',
    ],
    "rosapi_answers": [
        b'{"op":"service_response","service":"/rosapi/topics","values":{"topics":["/chatter","/rosout"],"types":["std_msgs/msg/String","rcl_interfaces/msg/Log"]},"result":true,"id":"/rosapi/topics"}',
        b'{"op":"service_response","service":"rosapi/topic_type","values":{"type":"std_msgs/msg/String"},"result":true,"id":"rosapi/topic_type"}',
        b'{"op":"service_response","service":"/rosapi/get_time","values":{"time":{"sec":1700000000,"nanosec":0}},"result":true,"id":"/rosapi/get_time"}',
        b'{"op":"service_response","service":"/rosapi/set_param","values":{"successful":true,"reason":""},"result":true,"id":"/rosapi/set_param"}',
        b'{"op":"service_response","service":"/rosapi/get_param","values":{"value":"[1, 2]","successful":true,"reason":""},"result":true,"id":"/rosapi/get_param"}',
        b'{"op":"service_response","service":"/rosapi/get_param","values":"rosapi_msgs/srv/GetParam_Request field \'name\': expected string, got int 3","result":false,"id":"/rosapi/get_param"}',
        b'{"op":"service_response","service":"/rosapi/message_details","values":{"typedefs":[{"type":"std_msgs/String","fieldnames":["data"],"fieldtypes":["string"],"fieldarraylen":[-1],"examples":[""],"constnames":[],"constvalues":[]}]},"result":true,"id":"/rosapi/message_details"}',
    ],
    "status_answers": [
        b'{"op":"status","level":"error","msg":"Unknown operation: bogus","id":"b1"}',
        b'{"op":"status","level":"error","msg":"malformed op: subscribe: field \'throttle_rate\' must be an integer, got \'fast\'"}',
        b'{"op":"status","level":"info","msg":"authentication is not enabled on this bridge; auth ignored","id":5}',
        b'{"op":"status","level":"error","msg":"Cannot infer topic type for topic /t as it is not yet advertised"}',
        b'{"op":"status","level":"error","msg":"undecodable frame: binary frame is neither CBOR nor JSON (invalid CBOR: break code encountered where a data item was expected)"}',
    ],
    "action_flow": [
        b'{"op":"send_action_goal","id":"action_goal:/fib:1","action":"/fib","action_type":"example_interfaces/action/Fibonacci","args":{"order":3},"feedback":true}',
        b'{"op":"send_action_goal","id":"action_goal:/fib:2","action":"/fib","action_type":"example_interfaces/action/Fibonacci","args":{"order":3},"feedback":true}',
        b'{"op":"send_action_goal","id":"action_goal:/fib:3","action":"/fib","action_type":"example_interfaces/action/Fibonacci","args":{"order":3},"feedback":true}',
        b'{"op":"action_feedback","action":"fib","values":{"sequence":[0,1]},"id":"g1"}',
        b'{"op":"action_feedback","action":"fib","values":{"sequence":[0]}}',
        b'{"op":"action_result","action":"fib","values":{"sequence":[0,1,1]},"status":4,"result":true,"id":"g1"}',
        b'{"op":"action_result","action":"fib","values":"gave up","status":6,"result":false,"id":"g2"}',
        b'{"op":"cancel_action_goal","id":"action_goal:/fib:3","action":"/fib"}',
        b'{"op":"action_result","action":"/none","values":"Action /none does not exist","status":6,"result":false,"id":9}',
        b'{"op":"action_result","action":"/fib","values":"malformed op: send_action_goal: field \'action_type\' is required","status":6,"result":false,"id":"no type"}',
        b'{"op":"send_action_goal","id":"action_goal:/fib:4","action":"/fib","action_type":"example_interfaces/action/Fibonacci","args":{"order":3},"feedback":true}',
        b'{"op":"cancel_action_goal","id":"action_goal:/fib:4","action":"/fib"}',
        b'{"op":"cancel_action_goal","id":"action_goal:/fib:3","action":"/fib"}',
        b'{"op":"cancel_action_goal","id":"action_goal:/fib:4","action":"/fib"}',
    ],
    "publish_encodings": [
        b'{"op":"publish","topic":"/img","msg":{"header":{"stamp":{"sec":1,"nanosec":2},"frame_id":"cam"},"format":"jpeg","data":"AAEC/w=="}}',
        b'{"op":"publish","topic":"f","msg":{"layout":{"dim":[],"data_offset":0},"data":[1.5,null,-0.0,1e+300]}}',
        b"cbor:a3626f70677075626c69736865746f706963642f696d67636d7367a366686561646572a2657374616d70a26373656301676e616e6f73656302686672616d655f69646363616d66666f726d6174646a706567646461746144000102ff",
        b"cbor:a3626f70677075626c69736865746f7069636166636d7367a2666c61796f7574a26364696d806b646174615f6f6666736574006464617461d8565820000000000000f83f000000000000f87f00000000000000809c7500883ce4377e",
        b"cbor:a3626f70677075626c69736865746f706963642f696d67636d7367a364736563731a6553f100656e736563730065627974657358280001000001000000020000000400000063616d00050000006a7065670000000004000000000102ff",
        b"cbor:a3626f70677075626c69736865746f7069636166636d7367a364736563731a6553f100656e736563730065627974657358340001000000000000000000000400000000000000000000000000f83f000000000000f87f00000000000000809c7500883ce4377e",
        b'{"op":"png","data":"iVBORw0KGgoAAAANSUhEUgAAAAYAAAAICAIAAABVpBlvAAAAn0lEQVQIHWOsVsr/ynB6k5+1w58vgn927twVxJhfkPll08X9vPreFjv37/Z2d93KaFWtpPfK/g+D4L6rnAyWP+1//WFUsqpmsHzluP7qOa4XtqY+jELfGZOVrM5Hf/rw0s2e/fO/P/8PX9zHmJyYu19mP8NL5wD2T0xbb67zMGNMTVc6vtvJNOjvwWMH5dmVmd4ZMdraKjk4vOjtZYADAPpHQM2w47RIAAAAAElFTkSuQmCC"}',
        b'{"op":"png","data":"iVBORw0KGgoAAAANSUhEUgAAAAUAAAAHCAIAAABPxRC5AAAAe0lEQVQIHQFwAI//AXsib/UAy7JOO0D89BH8uQEsInRDTvX0stG/ROgKvEsBc2cixxQAMuZXAxT7s8UHASJkaUu+0e478scHNVL9/gFvZmYE/w6v1bxb8vLnNVIBYSI6+g/02vtAQED+t8HEAS4wLAM1/wLLBSpNTa2NjXC8M6sOWobXAAAAAElFTkSuQmCC"}',
        b'{"op":"publish","topic":"/img","msg":{"header":{"stamp":{"sec":1,"nanosec":2},"frame_id":"cam"},"format":"jpeg","data":"AAEC/w=="}}',
        b'{"op":"publish","topic":"f","msg":{"layout":{"dim":[],"data_offset":0},"data":[1.5,null,-0.0,1e+300]}}',
    ],
    "fragments": (11, "9aed44c46c0a988249c250454d1bcf2d73ca17b90aa7ec240d335571df5ce487"),
}


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_reply_bytes_are_pinned(name: str, registry: TypeRegistry) -> None:
    sent = SCENARIOS[name](CoreHarness(registry))
    expected = EXPECTED[name]
    if isinstance(expected, tuple):
        digest = hashlib.sha256(b"\n".join(sent)).hexdigest()
        assert (len(sent), digest) == expected
    else:
        assert sent == expected


def test_fragments_carry_the_whole_text_in_order(registry: TypeRegistry) -> None:
    """The pinned fragments really are the reply cut at 1000 characters (not just a digest)."""
    h = CoreHarness(registry)
    provider, caller = provider_and_caller(h)
    h.send(caller, {"op": "call_service", "service": "/set", "id": "f", "fragment_size": 1000})
    message = "\u00e9" * 400 + "x" * 700
    h.send(
        provider,
        {
            "op": "service_response",
            "service": "/set",
            "values": {"success": True, "message": message},
            "id": "service_request:/set:1",
            "result": True,
        },
    )
    pieces = h.outbox(caller)
    whole = (
        '{"op":"service_response","service":"/set","values":{"success":true,"message":"'
        + "\\u00e9" * 400
        + "x" * 700
        + '"},"result":true,"id":"f"}'
    )
    assert [p["num"] for p in pieces] == [0, 1, 2, 3]
    assert all(p.keys() == {"op", "id", "data", "num", "total"} for p in pieces)
    assert {(p["op"], p["id"], p["total"]) for p in pieces} == {("fragment", "f", 4)}
    assert [p["data"] for p in pieces] == [whole[i : i + 1000] for i in range(0, 4000, 1000)]
