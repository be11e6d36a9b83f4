"""schemas.safety: what may enter the bridge, and how client input is echoed."""

from __future__ import annotations

import datetime
import timeit

import cbor2
import numpy as np
import pytest

from schemas.safety import ECHO_CHARS, MAX_DEPTH, echo, frame_problem, safe_text


def nested(depth: int) -> object:
    value: object = 1
    for _ in range(depth):
        value = [value]
    return value


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ({"msg": {"data": "a\ud800"}}, "field 'msg.data': a string with a lone surrogate"),
        ({"a": [1, 2**64]}, "field 'a[1]': an integer of 65 bits"),
        ({"a": -(2**63) - 1}, "an integer of 64 bits"),
        ({"a": 10**5000}, "an integer of 16610 bits"),
        ({"a": cbor2.undefined}, "UndefinedType"),
        ({"a": {1, 2}}, "type set"),
        ({"a": {1: 2}}, "a map key 1 that is not a UTF-8 string"),
        ({"a": {"\udc00": 2}}, "not a UTF-8 string"),
        ({"a": cbor2.CBORTag(999, 1)}, "CBORTag"),
        ({"a": datetime.datetime(2020, 1, 1)}, "datetime"),
        ({"a": nested(MAX_DEPTH + 1)}, f"nesting deeper than {MAX_DEPTH}"),
    ],
    ids=lambda value: value if isinstance(value, str) else "",
)
def test_values_no_encoder_could_write_are_named(value, problem):
    found = frame_problem(value)
    assert found is not None and problem in found


@pytest.mark.parametrize(
    "value",
    [
        {"op": "publish", "msg": {"data": "héllo \U0001f600", "n": 2**64 - 1, "m": -(2**63)}},
        {"a": float("nan"), "b": float("inf"), "c": None, "d": True},
        {"cloud": np.zeros(1_000_000, np.float32), "data": b"\x00" * 4_000_000},
        {"a": nested(MAX_DEPTH - 2)},
    ],
)
def test_values_that_can_be_carried_pass(value):
    assert frame_problem(value) is None


def test_bulk_data_is_skipped_not_walked():
    """The check must not cost in proportion to a scan: ndarrays and bytes are opaque."""
    scan = {
        "op": "publish",
        "topic": "/lidar",
        "msg": {
            "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "lidar"},
            "data": np.zeros(4_000_000, np.uint8),
            "fields": [{"name": "x"}] * 4,
        },
    }
    seconds = min(timeit.repeat(lambda: frame_problem(scan), number=100, repeat=3)) / 100
    assert seconds < 1e-3  # ~3 µs here; a Python walk of 4 M elements would take seconds


@pytest.mark.parametrize(
    "value",
    [
        10**5000,
        "x" * 100_000,
        "\ud800" * 10,
        b"\x00" * 10_000,
        list(range(10_000)),
        {str(i): i for i in range(10_000)},
        nested(5000),
        np.zeros(10**6),
        cbor2.CBORTag(1, 10**5000),
    ],
    ids=lambda value: type(value).__name__,
)
def test_echo_is_short_printable_and_never_raises(value):
    text = echo(value)
    assert len(text) <= ECHO_CHARS and text.isprintable()
    text.encode("utf-8")


def test_safe_text_keeps_one_line():
    assert safe_text("a\nb\x00c\ud800", 100) == "a\\nb\\x00c\\ud800"
    assert len(safe_text("y" * 1000, 50)) == 50
