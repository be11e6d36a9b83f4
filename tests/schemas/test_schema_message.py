"""normalize(): rosbridge's JSON -> ROS conversion rules (protocol reference §3.2)."""

import base64
import math

import numpy as np
import pytest

from schemas.errors import MessageValidationError, SchemaError
from schemas.message import default_message, normalize, ns_to_stamp, payload_bytes, stamp_to_ns

NOW_NS = 1_700_000_123_456_789_012


def norm(registry, type_name, raw):
    return normalize(registry.message(type_name), raw, now_ns=NOW_NS)


def test_missing_fields_take_defaults(registry):
    imu = norm(registry, "sensor_msgs/Imu", {"orientation": {"w": 1}})
    assert imu["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    assert imu["angular_velocity_covariance"] == [0.0] * 9
    assert imu["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}  # no header given
    assert list(imu) == [f.name for f in registry.message("sensor_msgs/Imu").fields]


@pytest.mark.parametrize("raw", [None, {}])
def test_none_and_empty_give_the_default_message(registry, raw):
    spec = registry.message("sensor_msgs/PointCloud2")
    out = normalize(spec, raw, now_ns=NOW_NS)
    assert out["data"] == b"" and out["fields"] == [] and out["is_dense"] is False
    expected = default_message(spec)
    assert out.keys() == expected.keys()


def test_default_message_is_fresh_each_time(registry):
    spec = registry.message("sensor_msgs/Imu")
    first = default_message(spec)
    first["orientation_covariance"][0] = 5.0
    first["header"]["frame_id"] = "x"
    second = default_message(spec)
    assert second["orientation_covariance"][0] == 0.0
    assert second["header"]["frame_id"] == ""
    grid = default_message(registry.message("nav_msgs/OccupancyGrid"))
    assert grid["data"].dtype == np.int8 and grid["data"].shape == (0,)


def test_unknown_field_is_an_error_naming_the_path(registry):
    with pytest.raises(MessageValidationError) as info:
        norm(registry, "geometry_msgs/PoseStamped", {"pose": {"position": {"w": 1.0}}})
    assert str(info.value) == (
        "geometry_msgs/msg/PoseStamped field 'pose.position.w': "
        "no such field in geometry_msgs/msg/Point"
    )


def test_bool_is_strict_with_the_rosbridge_message_shape(registry):
    with pytest.raises(MessageValidationError) as info:
        norm(registry, "std_srvs/srv/SetBool_Request", {"data": 42.0})
    assert str(info.value) == (
        "std_srvs/srv/SetBool_Request field 'data': expected bool, got float 42.0"
    )
    for bad in (1, 0, "true", None):
        with pytest.raises(MessageValidationError):
            norm(registry, "std_msgs/Bool", {"data": bad})
    assert norm(registry, "std_msgs/Bool", {"data": np.bool_(True)}) == {"data": True}


def test_ints(registry):
    assert norm(registry, "std_msgs/Int32", {"data": -5}) == {"data": -5}
    assert norm(registry, "std_msgs/UInt64", {"data": 2**64 - 1}) == {"data": 2**64 - 1}
    assert norm(registry, "std_msgs/Int16", {"data": np.int64(7)}) == {"data": 7}
    with pytest.raises(
        MessageValidationError, match=r"field 'data': expected int32, got float 1.0"
    ):
        norm(registry, "std_msgs/Int32", {"data": 1.0})
    with pytest.raises(MessageValidationError, match="expected int32, got bool"):
        norm(registry, "std_msgs/Int32", {"data": True})


@pytest.mark.parametrize(
    ("type_name", "low", "high"),
    [
        ("std_msgs/Int8", -128, 127),
        ("std_msgs/UInt8", 0, 255),
        ("std_msgs/Int16", -(2**15), 2**15 - 1),
        ("std_msgs/UInt16", 0, 2**16 - 1),
        ("std_msgs/Int32", -(2**31), 2**31 - 1),
        ("std_msgs/UInt32", 0, 2**32 - 1),
        ("std_msgs/Int64", -(2**63), 2**63 - 1),
        ("std_msgs/UInt64", 0, 2**64 - 1),
        ("std_msgs/Byte", 0, 255),
        ("std_msgs/Char", 0, 255),
    ],
)
def test_int_ranges(registry, type_name, low, high):
    assert norm(registry, type_name, {"data": low})["data"] == low
    assert norm(registry, type_name, {"data": high})["data"] == high
    for bad in (low - 1, high + 1):
        with pytest.raises(MessageValidationError, match="out of range"):
            norm(registry, type_name, {"data": bad})


def test_floats(registry):
    assert norm(registry, "std_msgs/Float64", {"data": 3}) == {"data": 3.0}
    assert isinstance(norm(registry, "std_msgs/Float64", {"data": 3})["data"], float)
    assert math.isnan(norm(registry, "std_msgs/Float64", {"data": None})["data"])
    assert norm(registry, "std_msgs/Float64", {"data": math.inf})["data"] == math.inf
    # float32 fields come back rounded through float32, like ROS 2 rosbridge.
    assert norm(registry, "std_msgs/Float32", {"data": 0.1})["data"] == 0.10000000149011612
    with pytest.raises(MessageValidationError, match="out of range for float32"):
        norm(registry, "std_msgs/Float32", {"data": 1e39})
    with pytest.raises(MessageValidationError, match="expected float64, got str"):
        norm(registry, "std_msgs/Float64", {"data": "1.5"})
    with pytest.raises(MessageValidationError, match="expected float64, got bool"):
        norm(registry, "std_msgs/Float64", {"data": False})


def test_strings(registry):
    assert norm(registry, "std_msgs/String", {"data": "héllo"}) == {"data": "héllo"}
    with pytest.raises(MessageValidationError, match="expected string, got int 5"):
        norm(registry, "std_msgs/String", {"data": 5})


def test_time_spellings(registry):
    for stamp in ({"sec": 3, "nanosec": 4}, {"secs": 3, "nsecs": 4}, {"sec": 3, "nsecs": 4}):
        out = norm(registry, "std_msgs/Header", {"stamp": stamp})
        assert out["stamp"] == {"sec": 3, "nanosec": 4}
    assert norm(registry, "builtin_interfaces/Time", "now") == ns_to_stamp(NOW_NS)
    assert norm(registry, "std_msgs/Header", {"stamp": "now"})["stamp"] == ns_to_stamp(NOW_NS)
    assert norm(registry, "builtin_interfaces/Duration", {"secs": -1})["sec"] == -1
    with pytest.raises(MessageValidationError, match="expected an object with sec/nanosec"):
        norm(registry, "builtin_interfaces/Duration", "now")
    with pytest.raises(MessageValidationError, match=r"field 'stamp\.nanosec': value -1 out of"):
        norm(registry, "std_msgs/Header", {"stamp": {"nanosec": -1}})
    with pytest.raises(
        MessageValidationError, match=r"field 'stamp\.sec': expected int32, got float"
    ):
        norm(registry, "std_msgs/Header", {"stamp": {"sec": 1.5}})


def test_header_without_stamp_is_stamped_now(registry):
    out = norm(registry, "sensor_msgs/Imu", {"header": {"frame_id": "imu"}})
    assert out["header"] == {"stamp": ns_to_stamp(NOW_NS), "frame_id": "imu"}
    assert norm(registry, "std_msgs/Header", {})["stamp"] == ns_to_stamp(NOW_NS)
    given = norm(registry, "sensor_msgs/Imu", {"header": {"stamp": {"sec": 1}}})
    assert given["header"]["stamp"] == {"sec": 1, "nanosec": 0}
    # Headers inside arrays follow the same rule.
    markers = norm(registry, "visualization_msgs/MarkerArray", {"markers": [{"header": {}}]})
    assert markers["markers"][0]["header"]["stamp"] == ns_to_stamp(NOW_NS)


def test_stamp_conversions():
    assert stamp_to_ns({"sec": 2, "nanosec": 5}) == 2_000_000_005
    assert stamp_to_ns({"secs": 2, "nsecs": 5}) == 2_000_000_005
    assert ns_to_stamp(2_000_000_005) == {"sec": 2, "nanosec": 5}
    assert ns_to_stamp(-1) == {"sec": -1, "nanosec": 999_999_999}
    assert stamp_to_ns(ns_to_stamp(NOW_NS)) == NOW_NS


def test_byte_arrays_accept_base64_lists_and_bytes(registry):
    raw = bytes(range(256))
    b64 = base64.b64encode(raw).decode()
    for value in (raw, b64, list(raw), bytearray(raw), np.frombuffer(raw, np.uint8)):
        assert norm(registry, "std_msgs/UInt8MultiArray", {"data": value})["data"] == raw
    assert norm(registry, "std_msgs/ByteMultiArray", {"data": [0, 255]})["data"] == b"\x00\xff"
    uuid = norm(registry, "unique_identifier_msgs/UUID", {"uuid": list(range(16))})
    assert uuid["uuid"] == bytes(range(16))
    with pytest.raises(MessageValidationError, match="exactly 16 elements, got 3"):
        norm(registry, "unique_identifier_msgs/UUID", {"uuid": [1, 2, 3]})
    with pytest.raises(MessageValidationError, match="field 'data': expected a list of ints"):
        norm(registry, "std_msgs/UInt8MultiArray", {"data": [1, 256]})
    with pytest.raises(MessageValidationError, match="base64"):
        norm(registry, "std_msgs/UInt8MultiArray", {"data": "not base64!"})


def test_already_canonical_bytes_and_arrays_are_not_copied(registry, pointcloud):
    out = norm(registry, "sensor_msgs/PointCloud2", pointcloud)
    assert out["data"] is pointcloud["data"]
    reflectance = np.zeros(1000, np.float32)
    radar = norm(registry, "riverbridge_msgs/RadarImage", {"reflectance": reflectance})
    assert radar["reflectance"] is reflectance


def test_numeric_sequences_become_exact_dtype_arrays(registry):
    out = norm(registry, "std_msgs/Float32MultiArray", {"data": [1, 2.5, None]})
    assert out["data"].dtype == np.float32
    assert out["data"][:2].tolist() == [1.0, 2.5] and np.isnan(out["data"][2])
    ints = norm(registry, "std_msgs/Int16MultiArray", {"data": np.arange(4, dtype=np.int64)})
    assert ints["data"].dtype == np.int16 and ints["data"].tolist() == [0, 1, 2, 3]
    big = norm(registry, "std_msgs/UInt64MultiArray", {"data": [2**64 - 1, 1]})
    assert big["data"].dtype == np.uint64 and int(big["data"][0]) == 2**64 - 1
    typed = norm(registry, "std_msgs/Float64MultiArray", {"data": np.arange(3, dtype=">f8")})
    assert typed["data"].dtype == np.float64 and typed["data"].tolist() == [0.0, 1.0, 2.0]
    empty = norm(registry, "std_msgs/Int32MultiArray", {"data": []})["data"]
    assert empty.dtype == np.int32 and empty.shape == (0,)


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ([1.5], "expected a list of int32 integers"),
        ([True], "expected a list of int32 integers"),
        (np.array([1.0]), "expected int32 values, got a float64 array"),
        ([2**31], "out of range for int32"),
        (np.array([-1, 2**40]), "out of range for int32"),
        ("abc", "expected a list of int32, got str"),
        (np.zeros((2, 2), np.int32), "expected a 1-D array"),
        ([[1, 2], [3, 4]], "expected a flat list of int32 numbers"),
        ([[1, 2], [3]], "expected a flat list of int32 numbers"),
        ([1, None], "expected a list of int32 integers"),
    ],
)
def test_numeric_sequence_errors(registry, value, problem):
    with pytest.raises(MessageValidationError, match="field 'data'") as info:
        norm(registry, "std_msgs/Int32MultiArray", {"data": value})
    assert problem in str(info.value)


def test_fixed_arrays_become_lists_of_length_n(registry):
    out = norm(registry, "sensor_msgs/Imu", {"orientation_covariance": np.arange(9)})
    assert out["orientation_covariance"] == [float(i) for i in range(9)]
    assert all(type(v) is float for v in out["orientation_covariance"])
    with pytest.raises(MessageValidationError) as info:
        norm(registry, "sensor_msgs/Imu", {"orientation_covariance": [0.0] * 8})
    assert str(info.value) == (
        "sensor_msgs/msg/Imu field 'orientation_covariance': expected exactly 9 elements, got 8"
    )
    mesh = norm(registry, "shape_msgs/MeshTriangle", {"vertex_indices": [1, 2, 3]})
    assert mesh["vertex_indices"] == [1, 2, 3]


def test_bounded_sequences(registry):
    spec = registry.message("rcl_interfaces/ParameterDescriptor")
    ok = normalize(spec, {"integer_range": [{"from_value": 1}]}, now_ns=0)
    assert ok["integer_range"][0]["from_value"] == 1
    with pytest.raises(MessageValidationError, match="at most 1 elements, got 2"):
        normalize(spec, {"integer_range": [{}, {}]}, now_ns=0)


def test_message_arrays_report_the_index(registry):
    with pytest.raises(MessageValidationError) as info:
        norm(registry, "sensor_msgs/PointCloud2", {"fields": [{"name": "x"}, {"offset": 1.5}]})
    assert str(info.value) == (
        "sensor_msgs/msg/PointCloud2 field 'fields[1].offset': expected uint32, got float 1.5"
    )
    with pytest.raises(MessageValidationError, match="field 'fields': expected a list"):
        norm(registry, "sensor_msgs/PointCloud2", {"fields": {"name": "x"}})


def test_bool_and_string_arrays(registry):
    out = norm(registry, "sensor_msgs/JointState", {"name": ["a", "b"]})
    assert out["name"] == ["a", "b"] and out["position"].dtype == np.float64
    with pytest.raises(MessageValidationError, match=r"field 'name\[1\]': expected string"):
        norm(registry, "sensor_msgs/JointState", {"name": ["a", 1]})
    spec = registry.message("rosapi_msgs/TypeDef")
    assert normalize(spec, {"fieldnames": ("x",)}, now_ns=0)["fieldnames"] == ["x"]


def test_top_level_must_be_an_object(registry):
    with pytest.raises(MessageValidationError) as info:
        norm(registry, "std_msgs/String", [1, 2])
    assert str(info.value).startswith("std_msgs/msg/String: expected an object")
    assert issubclass(MessageValidationError, SchemaError)


def test_nested_null_is_an_error(registry):
    with pytest.raises(MessageValidationError, match="field 'pose': expected an object"):
        norm(registry, "geometry_msgs/PoseStamped", {"pose": None})


def test_normalize_is_idempotent(registry, pointcloud):
    once = norm(registry, "sensor_msgs/PointCloud2", pointcloud)
    twice = norm(registry, "sensor_msgs/PointCloud2", once)
    assert twice == once


def test_declared_defaults_of_standard_messages(registry):
    # geometry_msgs/Quaternion declares w = 1: an omitted rotation is the identity.
    pose = norm(registry, "geometry_msgs/Pose", {})
    assert pose["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    assert norm(registry, "geometry_msgs/Quaternion", {"w": 0})["w"] == 0.0


def test_payload_bytes_counts_arrays_and_bytes_not_structure_or_text():
    msg = {
        "data": b"x" * 1000,
        "points": np.zeros((10, 4), np.float32),
        "header": {"frame_id": "abc"},
        "covariance": [0.0] * 9,
        "markers": [{"blob": b"y" * 5}],
    }
    assert payload_bytes(msg) == 1000 + 160 + 5


def test_ros1_header_seq_is_dropped_and_only_there(registry):
    msg = norm(registry, "std_msgs/msg/Header", {"seq": 4, "frame_id": "map"})
    assert msg == {"stamp": ns_to_stamp(NOW_NS), "frame_id": "map"}
    with pytest.raises(MessageValidationError, match="'seq': no such field"):
        norm(registry, "builtin_interfaces/msg/Duration", {"seq": 4})
    with pytest.raises(MessageValidationError, match=r"'header\.sequence': no such field"):
        norm(registry, "geometry_msgs/msg/PointStamped", {"header": {"sequence": 1}})
