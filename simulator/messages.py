"""Canonical ROS message dicts (docs/messages.md) for the simulator's outputs.

Every builder takes the capture time `stamp_ns` (wall-clock nanoseconds) from its caller; the
numeric core never reads a clock. `uint8[]` fields are `bytes`, numeric sequences 1-D numpy
arrays of the exact dtype, fixed-size arrays (covariances) lists of Python floats.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from schemas.values import Message
from simulator.frames import Pose2D, quaternion_from_yaw

#: A short vector (xyz, xyzw, variances): a tuple of floats or a 1-D float array.
Floats = Sequence[float] | npt.NDArray[np.float64]

MAP_FRAME = "map"
BASE_FRAME = "base_link"


def stamp(stamp_ns: int) -> Message:
    """builtin_interfaces/msg/Time from integer nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def header(stamp_ns: int, frame_id: str) -> Message:
    return {"stamp": stamp(stamp_ns), "frame_id": frame_id}


def vector3(xyz: Floats) -> Message:
    return {"x": float(xyz[0]), "y": float(xyz[1]), "z": float(xyz[2])}


def quaternion(xyzw: Floats) -> Message:
    return {"x": float(xyzw[0]), "y": float(xyzw[1]), "z": float(xyzw[2]), "w": float(xyzw[3])}


def diagonal_covariance(variances: Floats) -> list[float]:
    """Row-major n x n covariance with `variances` on the diagonal, as a list of floats."""
    return [float(v) for v in np.diag(np.asarray(variances, dtype=np.float64)).ravel()]


def compressed_image(jpeg: bytes, stamp_ns: int, frame_id: str) -> Message:
    """sensor_msgs/msg/CompressedImage holding one JPEG."""
    return {"header": header(stamp_ns, frame_id), "format": "jpeg", "data": bytes(jpeg)}


def transform_stamped(
    stamp_ns: int, parent: str, child: str, translation: Floats, rotation_xyzw: Floats
) -> Message:
    """geometry_msgs/msg/TransformStamped from `parent` to `child`."""
    return {
        "header": header(stamp_ns, parent),
        "child_frame_id": child,
        "transform": {"translation": vector3(translation), "rotation": quaternion(rotation_xyzw)},
    }


def tf_message(transforms: list[Message]) -> Message:
    """tf2_msgs/msg/TFMessage."""
    return {"transforms": transforms}


def vessel_tf(pose: Pose2D, water_level_m: float, stamp_ns: int) -> Message:
    """TFMessage map -> base_link for the vessel at `pose`."""
    translation = (pose.x_m, pose.y_m, water_level_m)
    return tf_message(
        [
            transform_stamped(
                stamp_ns, MAP_FRAME, BASE_FRAME, translation, quaternion_from_yaw(pose.yaw_rad)
            )
        ]
    )


def odometry(
    pose: Pose2D, water_level_m: float, velocity_body: Floats, yaw_rate_radps: float, stamp_ns: int
) -> Message:
    """nav_msgs/msg/Odometry ground truth: pose in `map`, twist in `base_link` (exact: zero cov).

    velocity_body : (surge u, sway v) m/s.
    """
    return {
        "header": header(stamp_ns, MAP_FRAME),
        "child_frame_id": BASE_FRAME,
        "pose": {
            "pose": {
                "position": {"x": float(pose.x_m), "y": float(pose.y_m), "z": float(water_level_m)},
                "orientation": quaternion(quaternion_from_yaw(pose.yaw_rad)),
            },
            "covariance": [0.0] * 36,
        },
        "twist": {
            "twist": {
                "linear": vector3((velocity_body[0], velocity_body[1], 0.0)),
                "angular": vector3((0.0, 0.0, yaw_rate_radps)),
            },
            "covariance": [0.0] * 36,
        },
    }
