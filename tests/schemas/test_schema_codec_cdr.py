import numpy as np
import pytest

from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import DecodeError, EncodeError
from schemas.message import normalize

CDR_LE_HEADER = b"\x00\x01\x00\x00"


def _imu(registry):
    raw = {
        "header": {"stamp": {"sec": 5, "nanosec": 6}, "frame_id": "imu_link"},
        "orientation": {"x": 0.1, "y": 0.2, "z": 0.3, "w": 0.9},
        "orientation_covariance": [float(i) for i in range(9)],
        "angular_velocity": {"z": -1.5},
        "linear_acceleration": {"z": 9.81},
        "linear_acceleration_covariance": [0.01] * 9,
    }
    return normalize(registry.message("sensor_msgs/Imu"), raw, now_ns=0)


def _rosbags_bytes(registry, type_name, build):
    store = registry.typestore
    return bytes(store.serialize_cdr(build(store.types), type_name))


def test_imu_round_trip_and_bytes_equal_rosbags(registry):
    msg = _imu(registry)
    data = to_cdr(registry, "sensor_msgs/msg/Imu", msg)
    assert data[:4] == CDR_LE_HEADER
    assert from_cdr(registry, "sensor_msgs/Imu", data) == msg

    def build(types):
        header = types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=5, nanosec=6), frame_id="imu_link"
        )
        vector = types["geometry_msgs/msg/Vector3"]
        return types["sensor_msgs/msg/Imu"](
            header=header,
            orientation=types["geometry_msgs/msg/Quaternion"](x=0.1, y=0.2, z=0.3, w=0.9),
            orientation_covariance=np.arange(9, dtype=np.float64),
            angular_velocity=vector(x=0.0, y=0.0, z=-1.5),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=vector(x=0.0, y=0.0, z=9.81),
            linear_acceleration_covariance=np.full(9, 0.01),
        )

    assert data == _rosbags_bytes(registry, "sensor_msgs/msg/Imu", build)


def test_pointcloud_round_trip_and_bytes_equal_rosbags(registry, pointcloud):
    msg = normalize(registry.message("sensor_msgs/PointCloud2"), pointcloud, now_ns=0)
    data = to_cdr(registry, "sensor_msgs/PointCloud2", msg)
    back = from_cdr(registry, "sensor_msgs/PointCloud2", data)
    assert back == msg and isinstance(back["data"], bytes)

    def build(types):
        fields = [types["sensor_msgs/msg/PointField"](**f) for f in pointcloud["fields"]]
        header = types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=1_700_000_000, nanosec=5),
            frame_id="lidar",
        )
        return types["sensor_msgs/msg/PointCloud2"](
            header=header,
            height=1,
            width=pointcloud["width"],
            fields=fields,
            is_bigendian=False,
            point_step=16,
            row_step=pointcloud["row_step"],
            data=np.frombuffer(pointcloud["data"], np.uint8),
            is_dense=True,
        )

    assert data == _rosbags_bytes(registry, "sensor_msgs/msg/PointCloud2", build)


def test_riverbridge_type_round_trip(registry):
    raw = {
        "header": {"frame_id": "radar"},
        "azimuth_step_rad": 0.087,
        "num_beams": 2,
        "num_cells": 3,
        "reflectance": np.arange(6, dtype=np.float32),
    }
    msg = normalize(registry.message("riverbridge_msgs/RadarImage"), raw, now_ns=42)
    back = from_cdr(
        registry,
        "riverbridge_msgs/RadarImage",
        to_cdr(registry, "riverbridge_msgs/RadarImage", msg),
    )
    assert back["reflectance"].dtype == np.float32
    assert back["reflectance"].tolist() == msg["reflectance"].tolist()
    assert {k: v for k, v in back.items() if k != "reflectance"} == {
        k: v for k, v in msg.items() if k != "reflectance"
    }
    boxes = normalize(
        registry.message("riverbridge_msgs/BoxArray"),
        {"method": "dbscan", "boxes": [{"cluster_id": 3, "max": {"x": 1.0}}]},
        now_ns=0,
    )
    assert (
        from_cdr(
            registry,
            "riverbridge_msgs/BoxArray",
            to_cdr(registry, "riverbridge_msgs/BoxArray", boxes),
        )
        == boxes
    )


def test_service_and_action_parts_round_trip(registry):
    spec = registry.service("rosapi_msgs/MessageDetails").response
    msg = normalize(spec, {"typedefs": registry.typedefs("geometry_msgs/Pose")}, now_ns=0)
    back = from_cdr(registry, spec.name, to_cdr(registry, spec.name, msg))
    assert back["typedefs"][0]["fieldnames"] == ["position", "orientation"]
    assert back["typedefs"][0]["fieldarraylen"].tolist() == [-1, -1]
    goal = registry.action("example_interfaces/Fibonacci").result
    msg = normalize(goal, {"sequence": [0, 1, 1, 2]}, now_ns=0)
    assert from_cdr(registry, goal.name, to_cdr(registry, goal.name, msg))["sequence"].tolist() == [
        0,
        1,
        1,
        2,
    ]


def test_bool_and_string_arrays_round_trip(registry):
    spec = registry.message("diagnostic_msgs/DiagnosticArray")
    msg = normalize(
        spec, {"status": [{"name": "a", "values": [{"key": "k", "value": "v"}]}]}, now_ns=0
    )
    assert from_cdr(registry, spec.name, to_cdr(registry, spec.name, msg)) == msg


def test_errors(registry):
    with pytest.raises(DecodeError):
        from_cdr(registry, "sensor_msgs/Imu", CDR_LE_HEADER + b"\x01")
    with pytest.raises(EncodeError):
        to_cdr(registry, "std_msgs/String", {"data": 5})


def test_byte_scalars_are_unsigned_octets(registry):
    # rosbags packs ``byte`` as a signed char; the wire bits must still be the octet 0..255.
    data = to_cdr(registry, "std_msgs/Byte", {"data": 255})
    assert data == CDR_LE_HEADER + b"\xff"
    assert from_cdr(registry, "std_msgs/Byte", data) == {"data": 255}
    assert from_cdr(registry, "std_msgs/Char", CDR_LE_HEADER + b"\xc8") == {"data": 200}
