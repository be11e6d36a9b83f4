"""Hostile rosbridge frames for the fuzz tests and `benchmarks/fuzz_probe.py`.

`HostileFrames(seed)` yields an endless, reproducible stream of websocket frames (str = text,
bytes = binary) built to reach the places a careless server breaks: valid ops with one field
replaced by a value that decodes but cannot be stored or encoded again (lone surrogates,
integers beyond 64 bits or 4,300 digits, ``1e400``, deep nesting, CBOR ``undefined``, sets,
non-string keys, unused tags, bignums), odd names and ids, amplification knobs
(``fragment_size``), byte-level mutations and garbage. Names stay under ``/fuzz``, away from
the healthy client's topic, so the fuzz may break nothing but itself.
"""

from __future__ import annotations

import json
import random
from collections.abc import Iterator
from typing import Any

import cbor2


class Raw(str):
    """Text written into a JSON frame verbatim (tokens `json.dumps` refuses to write)."""


SURROGATE = "\ud800"
BIG_DIGITS = Raw("1" + "0" * 5000)  # beyond Python's 4,300-digit int parsing limit
HUGE_FLOAT = Raw("1e400")  # parses to inf with the standard library
NAN = Raw("NaN")

NAMES = [
    "/fuzz/a",
    "fuzz/b",
    "/fuzz/c",
    "/fuzz/" + SURROGATE,
    "/fuzz/a\x00b",
    "/fuzz//x",
    "/fuzz/x/",
    "/fuzz/1x",
    "~/fuzz",
    "/fuzz/{ns}",
    "/fuzz/../etc",
    "/fuzz/ü",
    "",
    "/",
    "/fuzz/" + "n" * 300,
    "rosapi/topics",
    "/rosapi/get_param_names",
]
TYPES = [
    "std_msgs/String",
    "std_msgs/msg/Int64",
    "sensor_msgs/msg/Imu",
    "std_srvs/SetBool",
    "std_srvs/srv/Trigger",
    "example_interfaces/Fibonacci",
    "x",
    "",
    "a/b/c/d",
    "std_msgs/" + SURROGATE,
]


def hostile_values(rng: random.Random) -> list[Any]:
    """Values that decode in JSON but break naive code later."""
    depth = rng.choice([50, 300, 2000])
    return [
        SURROGATE,
        "ok" + SURROGATE + "ok",
        "\udfff",
        BIG_DIGITS,
        2**64,
        -(2**63) - 1,
        2**100,
        10**30,
        HUGE_FLOAT,
        Raw("-1e400"),
        NAN,
        Raw("Infinity"),
        1.5,
        -1,
        0,
        True,
        None,
        "",
        "x" * rng.choice([300, 5000, 70_000]),
        [1] * rng.choice([3, 1000]),
        Raw("[" * depth + "]" * depth),
        Raw('{"a":' * depth + "1" + "}" * depth),
        {"data": SURROGATE},
        {"data": BIG_DIGITS},
        {"data": HUGE_FLOAT},
        [SURROGATE],
        {"nested": {"deep": [1, {"x": SURROGATE}]}},
        {"sec": 2**40, "nanosec": -1},
    ]


def cbor_values(rng: random.Random) -> list[Any]:
    """Values only CBOR can carry: undefined, sets, non-string keys, tags we do not use."""
    depth = rng.choice([50, 390])
    nested: Any = 1
    for _ in range(depth):
        nested = [nested]
    return [
        cbor2.undefined,
        {1, 2, 3},
        frozenset({"a"}),
        {1: 2},
        {(1, 2): "x"},
        {b"k": 1},
        cbor2.CBORTag(999, "x"),
        cbor2.CBORTag(0, "2020-01-01T00:00:00Z"),
        cbor2.CBORTag(1, 1e300),
        cbor2.CBORTag(32, "http://x"),
        cbor2.CBORTag(86, b"abc"),
        cbor2.CBORTag(85, b"\x00" * 3),
        cbor2.CBORSimpleValue(99),
        10**400,
        -(10**5000),
        2**64,
        b"\xff\xfe",
        float("inf"),
        float("nan"),
        nested,
        {"data": cbor2.undefined},
        {"data": {1, 2}},
        {"data": 10**400},
    ]


TEMPLATES: list[dict[str, Any]] = [
    {"op": "advertise", "topic": "/fuzz/a", "type": "std_msgs/String", "id": "ad"},
    {"op": "unadvertise", "topic": "/fuzz/a", "id": "ad"},
    {"op": "publish", "topic": "/fuzz/a", "msg": {"data": "x"}},
    {"op": "publish", "topic": "/fuzz/i", "type": "std_msgs/msg/Int64", "msg": {"data": 1}},
    {
        "op": "publish",
        "topic": "/fuzz/imu",
        "type": "sensor_msgs/msg/Imu",
        "msg": {"header": {"frame_id": "f"}, "orientation_covariance": [0.0] * 9},
    },
    {
        "op": "subscribe",
        "topic": "/fuzz/a",
        "type": "std_msgs/String",
        "id": "s",
        "throttle_rate": 0,
        "queue_length": 1,
        "compression": "cbor",
    },
    {"op": "unsubscribe", "topic": "/fuzz/a", "id": "s"},
    {"op": "call_service", "service": "/rosapi/topics", "id": 1, "args": {}},
    {
        "op": "call_service",
        "service": "/rosapi/set_param",
        "id": 2,
        "args": {"name": "/fuzz:p", "value": "1"},
    },
    {"op": "call_service", "service": "/rosapi/get_param_names", "id": 3},
    {"op": "call_service", "service": "/fuzz/svc", "id": 4, "args": {"data": True}, "timeout": 0.2},
    {"op": "advertise_service", "service": "/fuzz/svc", "type": "std_srvs/SetBool"},
    {"op": "unadvertise_service", "service": "/fuzz/svc"},
    {
        "op": "service_response",
        "service": "/fuzz/svc",
        "id": "service_request:/fuzz/svc:1",
        "values": {"success": True, "message": "m"},
        "result": True,
    },
    {"op": "advertise_action", "action": "/fuzz/act", "type": "example_interfaces/Fibonacci"},
    {"op": "unadvertise_action", "action": "/fuzz/act"},
    {
        "op": "send_action_goal",
        "action": "/fuzz/act",
        "action_type": "example_interfaces/Fibonacci",
        "args": {"order": 3},
        "id": "g",
        "feedback": True,
    },
    {
        "op": "action_result",
        "action": "/fuzz/act",
        "id": "action_goal:/fuzz/act:1",
        "values": {"sequence": [0, 1]},
        "status": 4,
        "result": True,
    },
    {"op": "cancel_action_goal", "action": "/fuzz/act", "id": "g"},
    {"op": "fragment", "id": "f", "num": 0, "total": 2, "data": '{"op":"set_'},
    {"op": "set_level", "level": "error"},
    {
        "op": "auth",
        "mac": "00",
        "client": "c",
        "dest": "d",
        "rand": "r",
        "t": 0,
        "level": "admin",
        "end": 0,
    },
    {"op": "png", "data": "iVBORw0KGgo=", "id": "p"},
]

# Keys worth replacing: each op's own, plus the ones every op may carry.
EXTRA_KEYS = [
    "id",
    "op",
    "fragment_size",
    "compression",
    "msg",
    "args",
    "values",
    "type",
    "topic",
    "service",
    "action",
    "throttle_rate",
    "queue_length",
    "timeout",
    "latch",
    "status",
    "result",
    "level",
    "total",
    "num",
    "data",
]


def to_json(value: Any) -> str:
    """JSON text that may hold `Raw` tokens and lone surrogates (escaped as `\\ud800`)."""
    if isinstance(value, Raw):
        return str(value)
    if isinstance(value, dict):
        return "{" + ",".join(f"{to_json(str(k))}:{to_json(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ",".join(to_json(v) for v in value) + "]"
    if isinstance(value, float) and value != value:
        return "NaN"
    return json.dumps(value)


class HostileFrames:
    """An endless reproducible stream of hostile frames; `next(frames)` gives one."""

    def __init__(self, seed: int = 0, fragment_sizes: bool = True) -> None:
        self.rng = random.Random(seed)
        self.fragment_sizes = fragment_sizes
        self.count = 0

    def __iter__(self) -> Iterator[str | bytes]:
        return self

    def __next__(self) -> str | bytes:
        self.count += 1
        kind = self.rng.choices(["json", "cbor", "mutate", "garbage"], [55, 25, 12, 8])[0]
        return getattr(self, f"_{kind}")()

    def _op(self, values: list[Any]) -> dict[str, Any]:
        rng = self.rng
        op = dict(rng.choice(TEMPLATES))
        for key in ("topic", "service", "action"):
            if key in op and rng.random() < 0.3:
                op[key] = rng.choice(NAMES)
        if "type" in op and rng.random() < 0.2:
            op["type"] = rng.choice(TYPES)
        for _ in range(rng.choice([1, 1, 1, 2, 3])):
            key = rng.choice([*op, *EXTRA_KEYS])
            if key == "fragment_size" and not self.fragment_sizes:
                continue
            if key == "op" and rng.random() < 0.8:
                continue
            target = op
            if isinstance(op.get("msg"), dict) and rng.random() < 0.4:
                target = op["msg"] = dict(op["msg"])
                key = rng.choice([*target, "data", "header", "extra"])
            target[key] = rng.choice(values)
        return op

    def _json(self) -> str:
        return to_json(self._op(hostile_values(self.rng)))

    def _cbor(self) -> bytes:
        values = cbor_values(self.rng) + [
            v for v in hostile_values(self.rng) if not isinstance(v, str)
        ]
        op = self._op(values)
        try:
            return cbor2.dumps(op)
        except (ValueError, TypeError, cbor2.CBOREncodeError):
            return cbor2.dumps({"op": "publish", "topic": "/fuzz/a", "msg": cbor2.undefined})

    def _mutate(self) -> str | bytes:
        rng = self.rng
        base = to_json(rng.choice(TEMPLATES)).encode()
        data = bytearray(base if rng.random() < 0.7 else cbor2.dumps(rng.choice(TEMPLATES)))
        for _ in range(rng.randint(1, 4)):
            position = rng.randrange(len(data))
            action = rng.random()
            if action < 0.4:
                data[position] = rng.randrange(256)
            elif action < 0.7:
                del data[position:]
                if not data:
                    data = bytearray(b"{")
            else:
                data[position:position] = bytes(rng.randrange(256) for _ in range(3))
        return bytes(data)

    def _garbage(self) -> str | bytes:
        rng = self.rng
        if rng.random() < 0.5:
            return bytes(rng.randrange(256) for _ in range(rng.randint(0, 64)))
        return "".join(chr(rng.randrange(32, 0x2FFF)) for _ in range(rng.randint(0, 64)))
