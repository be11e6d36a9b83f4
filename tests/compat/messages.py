"""Sensor messages the compatibility scenarios publish, in rosbridge JSON form.

Values are deterministic (seeded) and far from defaults, so a dropped field, a zeroed array or
a byte-order slip shows up as a mismatch rather than passing by accident.
"""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np

# sensor_msgs/msg/PointField datatype code for FLOAT32 (PointField.msg constants).
POINTFIELD_FLOAT32 = 7
POINT_FIELDS = ("x", "y", "z", "intensity")
POINT_STEP_BYTES = 16

# A fixed, clearly non-zero stamp (2024-01-01T00:00:00Z + 0.123456789 s).
STAMP_SEC = 1_704_067_200
STAMP_NANOSEC = 123_456_789


@dataclass(frozen=True)
class PointCloud:
    """A published cloud and the points it encodes.

    points : (n, 4) float32, columns x_m, y_m, z_m, intensity (little-endian in `message`).
    """

    message: dict[str, Any]
    points: np.ndarray

    @property
    def data_sha256(self) -> str:
        return hashlib.sha256(self.points.astype("<f4").tobytes()).hexdigest()


def point_cloud(n_points: int, frame_id: str = "lidar", seed: int = 7) -> PointCloud:
    """An unorganised `sensor_msgs/msg/PointCloud2` of `n_points` xyz+intensity points."""
    rng = np.random.default_rng(seed)
    points = np.empty((n_points, 4), dtype=np.float32)
    points[:, :3] = rng.uniform(-120.0, 120.0, size=(n_points, 3))
    points[:, 3] = rng.uniform(0.0, 255.0, size=n_points)
    data = points.astype("<f4").tobytes()
    fields = [
        {"name": name, "offset": 4 * index, "datatype": POINTFIELD_FLOAT32, "count": 1}
        for index, name in enumerate(POINT_FIELDS)
    ]
    message = {
        "header": {"stamp": {"sec": STAMP_SEC, "nanosec": STAMP_NANOSEC}, "frame_id": frame_id},
        "height": 1,
        "width": n_points,
        "fields": fields,
        "is_bigendian": False,
        "point_step": POINT_STEP_BYTES,
        "row_step": POINT_STEP_BYTES * n_points,
        "data": base64.b64encode(data).decode("ascii"),
        "is_dense": True,
    }
    return PointCloud(message, points)


def covariance(first: float, step: float) -> list[float]:
    """A fixed-size float64[9] covariance with distinct, exactly printable entries."""
    return [round(first + step * index, 6) for index in range(9)]


def imu(frame_id: str = "imu_link") -> dict[str, Any]:
    """A `sensor_msgs/msg/Imu` with non-zero float64[9] covariances.

    Fixed-size arrays are what rosbridge's CBOR encoder dropped (issues #864/#965), so every
    covariance is distinct and non-zero.
    """
    return {
        "header": {"stamp": {"sec": STAMP_SEC, "nanosec": STAMP_NANOSEC}, "frame_id": frame_id},
        "orientation": {"x": 0.01, "y": -0.02, "z": 0.3826834, "w": 0.9238795},
        "orientation_covariance": covariance(0.001, 0.001),
        "angular_velocity": {"x": 0.5, "y": -0.25, "z": 0.125},
        "angular_velocity_covariance": covariance(0.02, 0.01),
        "linear_acceleration": {"x": 0.1, "y": 0.2, "z": 9.80665},
        "linear_acceleration_covariance": covariance(0.3, 0.05),
    }
