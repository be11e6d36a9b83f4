"""Messages and recordings for the recording tests, made without riverbridge's own writer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mcap_ros2.writer import Writer as Ros2Writer

from schemas.registry import TypeRegistry

NS_PER_S = 1_000_000_000
IMU = ("/imu/data", "sensor_msgs/msg/Imu")
CLOUD = ("/lidar/points", "sensor_msgs/msg/PointCloud2")
FIELDS = ("x", "y", "z", "intensity")


def stamp(ns: int) -> dict:
    return {"sec": ns // NS_PER_S, "nanosec": ns % NS_PER_S}


def imu(stamp_ns: int, index: int) -> dict:
    """An IMU sample whose yaw rate is ``index`` (so order can be checked after a trip)."""
    return {
        "header": {"stamp": stamp(stamp_ns), "frame_id": "imu_link"},
        "angular_velocity": {"x": 0.0, "y": 0.0, "z": float(index)},
        "linear_acceleration": {"x": 0.0, "y": 0.0, "z": 9.81},
    }


def cloud(stamp_ns: int, points: int, seed: int = 0) -> dict:
    """A canonical PointCloud2: (points, 4) float32 x, y, z, intensity."""
    data = np.random.default_rng(seed).random((points, 4), dtype=np.float32)
    return {
        "header": {"stamp": stamp(stamp_ns), "frame_id": "lidar"},
        "height": 1,
        "width": points,
        "fields": [
            {"name": name, "offset": 4 * k, "datatype": 7, "count": 1}
            for k, name in enumerate(FIELDS)
        ],
        "is_bigendian": False,
        "point_step": 16,
        "row_step": 16 * points,
        "data": data.tobytes(),
        "is_dense": True,
    }


def write_reference_recording(
    path: Path,
    registry: TypeRegistry,
    *,
    start_ns: int,
    imu_hz: float,
    cloud_hz: float,
    seconds: float,
    cloud_points: int = 1000,
) -> list[tuple[str, int, int]]:
    """An MCAP recording written with mcap-ros2-support's writer (not ours): an IMU topic and
    a PointCloud2 topic, ``log_time`` = stamp. Returns (topic, log_time_ns, index) in time
    order; ``index`` is the IMU's yaw rate and the cloud's seed."""
    events = [
        (IMU[0], start_ns + round(k * NS_PER_S / imu_hz), k) for k in range(int(seconds * imu_hz))
    ]
    events += [
        (CLOUD[0], start_ns + round(k * NS_PER_S / cloud_hz), k)
        for k in range(int(seconds * cloud_hz))
    ]
    events.sort(key=lambda event: event[1])
    with open(path, "wb") as stream:
        writer = Ros2Writer(stream)
        schemas = {
            name: writer.register_msgdef(name, registry.full_text(name)) for _, name in (IMU, CLOUD)
        }
        types = dict((IMU, CLOUD))
        for topic, log_ns, index in events:
            msg = imu(log_ns, index) if topic == IMU[0] else cloud(log_ns, cloud_points, index)
            writer.write_message(
                topic, schemas[types[topic]], msg, log_time=log_ns, publish_time=log_ns
            )
        writer.finish()
    return events
