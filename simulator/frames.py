"""Poses, rotations and quaternions (thesis 2.2) in the map frame.

Conventions (ROS REP 103): map x east, y north, z up; `base_link` x forward, y left, z up with
its origin on the water line; yaw counter-clockwise from east. Quaternions are (x, y, z, w).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulator.config import MountConfig


@dataclass(frozen=True)
class Pose2D:
    """Vessel pose in the map frame: position of `base_link` (metres) and heading (radians)."""

    x_m: float
    y_m: float
    yaw_rad: float


def rotation_z(yaw_rad: float) -> np.ndarray:
    """(3, 3) rotation about z by `yaw_rad` (counter-clockwise)."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_y(pitch_rad: float) -> np.ndarray:
    """(3, 3) rotation about y; positive pitch turns +x towards -z (nose down)."""
    c, s = np.cos(pitch_rad), np.sin(pitch_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def mount_rotation(mount: MountConfig) -> np.ndarray:
    """(3, 3) rotation from the sensor frame to `base_link`."""
    return rotation_y(np.radians(mount.pitch_deg))


def sensor_pose_in_map(
    pose: Pose2D, mount: MountConfig, water_level_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Sensor origin (3,) and rotation sensor->map (3, 3) for a vessel at `pose`."""
    yaw = rotation_z(pose.yaw_rad)
    base_origin = np.array([pose.x_m, pose.y_m, water_level_m])
    origin = base_origin + yaw @ np.array([mount.x_m, mount.y_m, mount.z_m])
    return origin, yaw @ mount_rotation(mount)


def rotate_rows(vectors: np.ndarray, rotation: np.ndarray, out: np.ndarray) -> np.ndarray:
    """out[i] = rotation @ vectors[i] for (n, 3) float32 `vectors`, written into `out`."""
    return np.matmul(vectors, np.asarray(rotation, out.dtype).T, out=out)


def quaternion_from_yaw(yaw_rad: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by `yaw_rad` about z."""
    half = 0.5 * yaw_rad
    return (0.0, 0.0, float(np.sin(half)), float(np.cos(half)))


def quaternion_from_matrix(rotation: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a proper (3, 3) rotation matrix (Shepperd's method, w >= 0)."""
    m = np.asarray(rotation, dtype=np.float64)
    trace = np.trace(m)
    candidates = np.array([trace, m[0, 0], m[1, 1], m[2, 2]])
    k = int(np.argmax(candidates))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + trace)
        q = (
            (m[2, 1] - m[1, 2]) / (4 * w),
            (m[0, 2] - m[2, 0]) / (4 * w),
            (m[1, 0] - m[0, 1]) / (4 * w),
            w,
        )
    else:
        i, j, h = k - 1, k % 3, (k + 1) % 3
        v = np.zeros(3)
        v[i] = 0.5 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[h, h])
        v[j] = (m[j, i] + m[i, j]) / (4 * v[i])
        v[h] = (m[h, i] + m[i, h]) / (4 * v[i])
        w = (m[h, j] - m[j, h]) / (4 * v[i])
        q = (v[0], v[1], v[2], w)
    q_arr = np.array(q) * (1.0 if q[3] >= 0 else -1.0)
    return tuple(float(c) for c in q_arr / np.linalg.norm(q_arr))  # type: ignore[return-value]


def wrap_angle_rad(angle_rad: float) -> float:
    """Angle wrapped into [-pi, pi)."""
    return float((angle_rad + np.pi) % (2 * np.pi) - np.pi)
