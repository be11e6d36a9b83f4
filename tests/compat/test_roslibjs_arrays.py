"""Numeric arrays as roslibjs receives them: RFC 8746 typed arrays over CBOR (decoded by
roslibjs's own CBOR reader), plain lists over JSON, non-finite floats kept in CBOR and
written as null in JSON (protocol §4.3, DESIGN §3)."""

from __future__ import annotations

import math
from typing import Any

import pytest

from .bridge_process import BridgeEndpoint
from .node_runner import publish_while_running
from .wire import wire_peer

# (message type, data values exactly representable in that type, JS container that
# roslibjs's CBOR decoder yields)
TYPED_SEQUENCES = [
    ("std_msgs/msg/UInt16MultiArray", [0, 1, 65535], "Uint16Array"),
    ("std_msgs/msg/UInt32MultiArray", [0, 7, 4294967295], "Uint32Array"),
    ("std_msgs/msg/Int8MultiArray", [-128, 0, 127], "Int8Array"),
    ("std_msgs/msg/Int16MultiArray", [-32768, 5, 32767], "Int16Array"),
    ("std_msgs/msg/Int32MultiArray", [-2147483648, 9, 2147483647], "Int32Array"),
    ("std_msgs/msg/Float32MultiArray", [0.5, -1.25, 2.0**100], "Float32Array"),
    ("std_msgs/msg/Float64MultiArray", [0.1, -2.5e-300, 1.0e300], "Float64Array"),
]


def multi_array(values: list[Any]) -> dict[str, Any]:
    return {"layout": {"dim": [], "data_offset": 0}, "data": values}


async def first_message_in_roslibjs(
    bridge: BridgeEndpoint, type_name: str, message: dict, compression: str
) -> dict[str, Any]:
    """Publish until roslibjs has a message; each (type, compression) gets its own topic so
    the tests can share one bridge."""
    topic = f"/compat/{type_name.rsplit('/', 1)[-1].lower()}_{compression}"
    async with wire_peer(bridge.url) as publisher:
        result = await publish_while_running(
            publisher, topic, type_name, message,
            "subscribe_first.mjs", bridge.url, topic, type_name, compression,
        )  # fmt: skip
    assert result["status_ops"] == []
    return result["message"]


@pytest.mark.parametrize(("type_name", "values", "js_container"), TYPED_SEQUENCES)
async def test_cbor_numeric_sequences_arrive_as_typed_arrays(
    module_bridge: BridgeEndpoint, type_name: str, values: list, js_container: str
) -> None:
    received = await first_message_in_roslibjs(
        module_bridge, type_name, multi_array(values), "cbor"
    )
    assert received["data"] == {"$typed": js_container, "values": values}
    assert received["layout"] == {"dim": [], "data_offset": 0}


@pytest.mark.parametrize(("type_name", "values", "js_container"), TYPED_SEQUENCES)
async def test_json_numeric_sequences_arrive_as_plain_lists(
    module_bridge: BridgeEndpoint, type_name: str, values: list, js_container: str
) -> None:
    """Values must come back as the exact numbers of the field type: rosbridge writes a
    float32 as the double it equals (2**100 stays 1.2676506002282294e+30; 0.1 comes back
    0.10000000149011612), so a client reading it gets the value the ROS side holds."""
    received = await first_message_in_roslibjs(
        module_bridge, type_name, multi_array(values), "none"
    )
    assert received["data"] == values


@pytest.mark.parametrize(
    ("compression", "expected"),
    [("cbor", {"$typed": "Uint8Array", "values": [0, 7, 255]}), ("none", "AAf/")],
)
async def test_uint8_sequence_is_bytes_in_cbor_and_base64_in_json(
    module_bridge: BridgeEndpoint, compression: str, expected: Any
) -> None:
    """uint8[] is a CBOR byte string (not tag 64) and a base64 string in JSON; the publisher
    sends a list of ints, which rosbridge accepts as well as base64."""
    received = await first_message_in_roslibjs(
        module_bridge, "std_msgs/msg/UInt8MultiArray", multi_array([0, 7, 255]),
        compression,
    )  # fmt: skip
    assert received["data"] == expected


@pytest.mark.parametrize(
    ("compression", "expected_ranges"),
    [
        (
            "cbor",
            {"$typed": "Float32Array", "values": [
                1.5, {"$float": "NaN"}, {"$float": "Infinity"}, {"$float": "-Infinity"}, 2.25,
            ]},
        ),
        ("none", [1.5, None, None, None, 2.25]),
    ],
)  # fmt: skip
async def test_non_finite_ranges_from_nan_tokens(
    module_bridge: BridgeEndpoint, compression: str, expected_ranges: Any
) -> None:
    """The publisher writes bare NaN/Infinity tokens (as roslibpy does); CBOR keeps them,
    JSON turns them into null (what JSON.parse can read)."""
    scan = {
        "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "radar"},
        "angle_min": -1.5, "angle_max": 1.5, "angle_increment": 0.75,
        "time_increment": 0.0, "scan_time": 0.5, "range_min": 0.5, "range_max": 1200.0,
        "ranges": [1.5, math.nan, math.inf, -math.inf, 2.25],
        "intensities": [],
    }  # fmt: skip
    received = await first_message_in_roslibjs(
        module_bridge, "sensor_msgs/msg/LaserScan", scan, compression
    )
    assert received["ranges"] == expected_ranges
    assert received["range_max"] == 1200.0
