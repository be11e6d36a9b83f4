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
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from schemas import message as message_module
from schemas import primitives, specs
from schemas.errors import MessageValidationError
from schemas.message import normalize
from schemas.registry import TypeRegistry
from schemas.specs import FieldSpec, MessageSpec
from tests.schemas.test_schema_properties import _garbage_for, message_strategy

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
    """Random messages of a type, mostly valid, in the forms clients send: fields missing,
    ints for floats, ROS 1 times, "now", a header without a stamp or with `seq`. The shared
    strategies of test_schema_properties.py write every field in canonical form; they are
    run against the shortcut too (`test_canonical_and_garbage_messages_agree`)."""

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
        return self.rng.choice(
            [
                0.0,
                -1.5,
                0.1,
                1e300,
                3.4028235e38,
                3,
                2**60 + 1,
                2**53 + 1,
                self.rng.uniform(-1e6, 1e6),
            ]
        )

    def string(self, field: FieldSpec) -> str:
        bound = field.string_bound or 12
        return "".join(self.rng.choice('aé话 \n"') for _ in range(self.rng.randrange(bound + 1)))


BROKEN = [None, True, 1, 1.5, "x", [], {}, [1.5], {"x": 1}, -1, 300, 70_000, 2**32, 2**63, 2**64]
BROKEN += [-(2**63) - 1]


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


def test_nested_types_compile_and_those_normalize_reshapes_or_walks_quicker_do_not():
    assert len(COMPILED) > 100
    for name in ("sensor_msgs/msg/Imu", "geometry_msgs/msg/Twist", "sensor_msgs/msg/Range"):
        assert name in COMPILED
    uncompiled = (
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/Image",
        "std_msgs/msg/String",  # flat and small: the walk is quicker
    )
    for name in uncompiled:
        assert REGISTRY.message(name).compiled_check is None  # bytes, ndarrays


@pytest.mark.parametrize("name", COMPILED)
def test_the_shortcut_gives_what_the_walk_gives_or_leaves_it_to_the_walk(name):
    _agree(REGISTRY.message(name), random.Random(name), 60)


# Every kind of field a compiled type can have, several in forms the registry's types lack
# (float32 and integer fixed arrays, bounded strings in bounded arrays, uint64 values).
MIXED = {
    "Inner.msg": "float32 x\nint16 y\nstring<=5 z\nfloat64 w\nbool b\n",
    "Mixed.msg": (
        "float32[3] f32s\nfloat64[2] f64s\nint8[2] i8s\nuint64[2] u64s\nuint64 big\n"
        "float32 one\nstring<=4 short\nstring<=3[2] words\nbool[<=2] flags\n"
        "Inner[<=2] inners\nInner[2] pair\nInner[] many\nstd_msgs/Header header\n"
        "builtin_interfaces/Duration span\n"
    ),
}


# `normalize` casts a float32 array's 1e300 to inf, and numpy warns as it does.
@pytest.mark.filterwarnings("ignore:overflow encountered in cast:RuntimeWarning")
def test_types_with_every_kind_of_field_agree_too(tmp_path):
    folder = tmp_path / "rbcheck_msgs" / "msg"
    folder.mkdir(parents=True)
    for file_name, text in MIXED.items():
        (folder / file_name).write_text(text)
    registry = TypeRegistry.with_defaults()
    registry.add_directory(tmp_path)
    for name in ("rbcheck_msgs/msg/Inner", "rbcheck_msgs/msg/Mixed"):
        spec = registry.message(name)
        assert spec.compiled_check is not None
        _agree(spec, random.Random(name), 3000)


def test_large_ints_in_a_float32_array_are_rounded_once(tmp_path):
    """2**53 + 2**29 + 1 as float64 is a float32 midpoint: rounded twice it would go down;
    the walk casts the int straight to float32 and goes up."""
    folder = tmp_path / "rbcheck_msgs" / "msg"
    folder.mkdir(parents=True)
    (folder / "Floats.msg").write_text("float32[3] values\n")
    registry = TypeRegistry.with_defaults()
    registry.add_directory(tmp_path)
    spec = registry.message("rbcheck_msgs/msg/Floats")
    raw = {"values": [2**53 + 2**29 + 1, 0, 0]}
    assert normalize(spec, raw, now_ns=0) == {"values": [float(2**53 + 2**30), 0.0, 0.0]}


def _agree(spec: MessageSpec, rng: random.Random, rounds: int) -> None:
    check = spec.compiled_check
    maker = Maker(rng)
    taken = 0
    for round_ in range(rounds):
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
    assert taken > 0, spec.name  # the shortcut did take some


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
    twist = REGISTRY.message("geometry_msgs/msg/Twist")
    numpy_values = {"linear": {"x": np.float64(0.5), "y": np.float32(0.25), "z": np.int64(3)}}
    assert twist.compiled_check(numpy_values) is None  # numpy scalars: the walk converts them
    assert _same(
        normalize(twist, numpy_values, now_ns=0)["linear"], {"x": 0.5, "y": 0.25, "z": 3.0}
    )
    numpy_value = normalize(REGISTRY.message("std_msgs/msg/Int32"), {"data": np.int32(4)}, now_ns=0)
    assert _same(numpy_value, {"data": 4})


def test_float32_values_are_rounded_and_range_checked_as_the_walk_does():
    spec = REGISTRY.message("riverbridge_msgs/msg/RadarDetection")
    assert spec.compiled_check is not None
    assert spec.compiled_check({"power": 0.1})["power"] == 0.10000000149011612
    assert normalize(spec, {"power": 0.1}, now_ns=0)["power"] == 0.10000000149011612
    assert spec.compiled_check({"power": 1e39}) is None  # past float32: the walk refuses it
    with pytest.raises(MessageValidationError, match="out of range for float32"):
        normalize(spec, {"power": 1e39}, now_ns=0)
    assert normalize(spec, {"power": math.inf}, now_ns=0)["power"] == math.inf  # (CBOR's)
    detections = REGISTRY.message("riverbridge_msgs/msg/RadarDetectionArray")
    raw = {"detections": [{"x_m": 0.1 * i, "y_m": -0.3} for i in range(50)]}
    got = detections.compiled_check(raw)
    assert got is not None and _same(got, normalize(detections, raw, now_ns=NOW_NS))
    assert got["detections"][7]["x_m"] == float(np.float32(0.7000000000000001))
    polygon = REGISTRY.message("geometry_msgs/msg/Polygon")
    assert polygon.compiled_check({"points": [{"x": 0.1}, {"y": 0.2}]}) == normalize(
        polygon, {"points": [{"x": 0.1}, {"y": 0.2}]}, now_ns=0
    )


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


COMPILED_SPECS = st.sampled_from(COMPILED).map(REGISTRY.message)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    COMPILED_SPECS.flatmap(
        lambda spec: st.tuples(
            st.just(spec), message_strategy(spec, finite=False) | _garbage_for(spec)
        )
    )
)
def test_canonical_and_garbage_messages_agree(case):
    """The project's message strategies (full-width floats, NaN and inf, any text, any JSON
    under the type's own field names): the shortcut agrees with the walk on them too."""
    spec, raw = case
    got = spec.compiled_check(raw)
    if got is not None:
        expected = _walk(spec, raw)
        assert expected != "refused", f"the shortcut accepted what the walk refuses: {raw!r}"
        assert _same(got, expected), f"{raw!r}: {got!r} != {expected!r}"


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
