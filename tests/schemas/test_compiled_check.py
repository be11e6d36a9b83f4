"""The compiled check (`schemas.compiled_check`) is only a shortcut of `normalize`'s walk: for
every registered type it compiles, on random valid messages and on broken ones, it either
leaves the message to the walk or gives exactly what the walk gives (same values, same
Python types, same key order)."""

from __future__ import annotations

import math
import random
from typing import Any

import numpy as np
import pytest

from schemas import message as message_module
from schemas import primitives, specs
from schemas.errors import MessageValidationError
from schemas.message import normalize
from schemas.registry import TypeRegistry
from schemas.specs import FieldSpec, MessageSpec

NOW_NS = 1_700_000_000_123_456_789
REGISTRY = TypeRegistry.with_defaults()
COMPILED = [n for n in REGISTRY.message_names() if REGISTRY.message(n).compiled_check]


def _walk(spec: MessageSpec, raw: Any) -> Any:
    """`normalize` without the shortcut: the reference."""
    try:
        return message_module._message(spec, raw, NOW_NS)
    except message_module._FieldError:
        return "refused"


def _same(a: Any, b: Any) -> bool:
    """Equal, with the same types all the way down (a float is not an int) and key order."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    return bool(a == b)


class Maker:
    """Random messages of a type: mostly valid, in the forms clients send."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng

    def message(self, spec: MessageSpec, depth: int = 0) -> Any:
        rng = self.rng
        if spec.name in primitives.TIME_TYPES:
            form = rng.random()
            if form < 0.05 and spec.name.endswith("/Time"):
                return "now"
            keys = ("secs", "nsecs") if form < 0.1 else ("sec", "nanosec")
            out = {}
            if rng.random() < 0.9:
                out[keys[0]] = rng.choice([0, 1, -1, 2**31 - 1, -(2**31), rng.randrange(10**9)])
            if rng.random() < 0.9:
                out[keys[1]] = rng.choice([0, 999_999_999, 2**32 - 1, rng.randrange(10**9)])
            return out
        out = {}
        for field in spec.fields:
            if rng.random() < 0.15:
                continue  # missing: its default (a Header's stamp: now)
            out[field.name] = self.value(field, depth)
        if spec.name == primitives.HEADER_TYPE and rng.random() < 0.05:
            out["seq"] = 7  # ROS 1's, dropped
        return out

    def value(self, field: FieldSpec, depth: int) -> Any:
        rng, category = self.rng, field.category
        if category == specs.BOOL:
            return rng.random() < 0.5
        if category == specs.INT:
            return self.integer(field.base)
        if category == specs.FLOAT:
            return self.floating()
        if category == specs.STRING:
            return self.string(field)
        if category == specs.MESSAGE:
            return self.message(field.message, depth + 1)
        if category == specs.NUMERIC_FIXED:
            make = self.floating if field.base in primitives.FLOAT_DTYPES else None
            return [make() if make else self.integer(field.base) for _ in range(field.length)]
        count = self.count(field)
        if category == specs.BOOL_ARRAY:
            return [rng.random() < 0.5 for _ in range(count)]
        if category == specs.STRING_ARRAY:
            return [self.string(field) for _ in range(count)]
        if category == specs.MESSAGE_ARRAY:
            return [self.message(field.message, depth + 1) for _ in range(min(count, 3))]
        raise AssertionError(category)

    def count(self, field: FieldSpec) -> int:
        if field.array == "fixed":
            return field.length
        if field.array == "bounded":
            return self.rng.randrange(field.length + 1)
        return self.rng.randrange(4)

    def integer(self, base: str) -> int:
        low, high = primitives.INT_RANGES[base]
        return self.rng.choice([low, high, 0, 1, self.rng.randint(low, high)])

    def floating(self) -> Any:
        return self.rng.choice([0.0, -1.5, 1e300, 3, 2**60 + 1, self.rng.uniform(-1e6, 1e6)])

    def string(self, field: FieldSpec) -> str:
        bound = field.string_bound or 12
        return "".join(self.rng.choice('aé话 \n"') for _ in range(self.rng.randrange(bound + 1)))


BROKEN = [None, True, 1, 1.5, "x", [], {}, [1.5], {"x": 1}, 2**64, -(2**63) - 1, 2**63]


def _break(rng: random.Random, raw: Any) -> Any:
    """`raw` with one value somewhere replaced by something of another kind, or a key added."""
    if not isinstance(raw, dict) or not raw:
        return rng.choice(BROKEN)
    key = rng.choice(list(raw))
    out = dict(raw)
    roll = rng.random()
    if roll < 0.1:
        out["no_such_field"] = 1
    elif roll < 0.2 and isinstance(raw[key], list) and raw[key]:
        out[key] = raw[key] * 3  # past a bound or a fixed length
    elif roll < 0.25 and isinstance(raw[key], str):
        out[key] = raw[key] + "x" * 300  # past a string bound
    elif roll < 0.5 and isinstance(raw[key], dict | list) and raw[key]:
        value = raw[key]
        out[key] = (
            _break(rng, value) if isinstance(value, dict) else [_break(rng, item) for item in value]
        )
    else:
        out[key] = rng.choice(BROKEN)
    return out


def test_most_types_compile_and_the_ones_normalize_reshapes_do_not():
    assert len(COMPILED) > 150
    for name in ("sensor_msgs/msg/Imu", "geometry_msgs/msg/Twist", "std_msgs/msg/String"):
        assert name in COMPILED
    uncompiled = (
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/LaserScan",
        "std_msgs/msg/Float32",
    )
    for name in uncompiled:
        assert REGISTRY.message(name).compiled_check is None  # bytes, ndarrays, float32


@pytest.mark.parametrize("name", COMPILED)
def test_the_shortcut_gives_what_the_walk_gives_or_leaves_it_to_the_walk(name):
    spec = REGISTRY.message(name)
    check = spec.compiled_check
    rng = random.Random(name)
    maker = Maker(rng)
    taken = 0
    for round_ in range(60):
        raw = maker.message(spec)
        if round_ % 2:
            raw = _break(rng, raw)
        expected = _walk(spec, raw)
        got = check(raw)
        if got is None:
            continue  # the walk decides: that is normalize's own answer
        taken += 1
        assert expected != "refused", f"the shortcut accepted what the walk refuses: {raw!r}"
        assert _same(got, expected), f"{raw!r}: {got!r} != {expected!r}"
        assert _same(normalize(spec, raw, now_ns=NOW_NS), expected)
    assert taken > 0  # the shortcut did take some


def test_forms_only_the_walk_knows_still_work():
    """null for NaN, "now", secs/nsecs, a header without a stamp, ROS 1's seq, big uint64."""
    imu = REGISTRY.message("sensor_msgs/msg/Imu")
    assert imu.compiled_check is not None
    msg = normalize(
        imu,
        {"header": {"frame_id": "imu", "seq": 3}, "orientation": {"x": None}},
        now_ns=NOW_NS,
    )
    assert msg["header"]["stamp"] == {"sec": 1_700_000_000, "nanosec": 123_456_789}
    assert math.isnan(msg["orientation"]["x"])
    stamped = normalize(
        REGISTRY.message("std_msgs/msg/Header"), {"stamp": {"secs": 5, "nsecs": 6}}, now_ns=0
    )
    assert stamped == {"stamp": {"sec": 5, "nanosec": 6}, "frame_id": ""}
    big = normalize(REGISTRY.message("std_msgs/msg/UInt64"), {"data": 2**64 - 1}, now_ns=0)
    assert big == {"data": 2**64 - 1}
    numpy_value = normalize(REGISTRY.message("std_msgs/msg/Int32"), {"data": np.int32(4)}, now_ns=0)
    assert _same(numpy_value, {"data": 4})


def test_a_missing_header_is_all_zeros_and_a_missing_stamp_is_now():
    imu = REGISTRY.message("sensor_msgs/msg/Imu")
    assert normalize(imu, {}, now_ns=NOW_NS)["header"]["stamp"] == {"sec": 0, "nanosec": 0}
    assert normalize(imu, {"header": {}}, now_ns=NOW_NS)["header"]["stamp"]["sec"] == 1_700_000_000


def test_errors_still_name_the_field():
    imu = REGISTRY.message("sensor_msgs/msg/Imu")
    with pytest.raises(MessageValidationError, match=r"field 'orientation\.w': expected float64"):
        normalize(imu, {"orientation": {"w": "one"}}, now_ns=0)
    with pytest.raises(MessageValidationError, match="expected exactly 9 elements, got 2"):
        normalize(imu, {"orientation_covariance": [0.0, 1.0]}, now_ns=0)


def test_defaults_are_fresh_for_every_message():
    """A missing list field must not be one list shared by every message of the type."""
    spec = REGISTRY.message("sensor_msgs/msg/Imu")
    first = normalize(spec, {}, now_ns=0)
    first["orientation_covariance"][0] = 99.0
    first["header"]["frame_id"] = "changed"
    second = normalize(spec, {}, now_ns=0)
    assert second["orientation_covariance"][0] == 0.0 and second["header"]["frame_id"] == ""


def test_every_length_and_bound_is_kept():
    """For each bounded or fixed array and each bounded string of a compiled type, one element
    or character too many: refused by the shortcut exactly as by the walk."""
    maker = Maker(random.Random(1))
    checked = 0
    for name in COMPILED:
        spec = REGISTRY.message(name)
        for field in spec.fields:
            if field.array in ("fixed", "bounded"):
                element = maker.value(field, 0)[:1] or [maker.value(field, 0)]
                too_long = [*element] * (field.length + 1) if element else None
                if too_long is None:  # an empty bounded list: make one element first
                    continue
            elif field.string_bound:
                too_long = "x" * (field.string_bound + 1)
            else:
                continue
            raw = {field.name: too_long}
            assert _walk(spec, raw) == "refused", (name, field.name)
            assert spec.compiled_check(raw) is None, (name, field.name)
            checked += 1
    assert checked >= 10
