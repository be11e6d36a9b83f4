"""Messages in and out of guidance: canonical ROS messages <-> numpy arrays, no I/O.

In: nav_msgs/Odometry (the pose), nav_msgs/OccupancyGrid (navigation's fused obstacle map,
vessel frame), riverbridge_msgs/BoxArray (LIDAR boxes, lidar frame) and RadarDetectionArray
(radar targets, radar frame). Vessel-frame obstacles are turned into the map frame with the
pose *at their stamp* (`PoseHistory`), so a map that arrives 300 ms after its scan is not
placed 1 m ahead of where it was seen. Out: WrenchStamped, Path, PointStamped, String.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from guidance.control import Wrench
from guidance.pilot import VesselPose

NS_PER_S = 1_000_000_000
OCCUPIED = 50  # OccupancyGrid: 0 free .. 100 occupied, -1 unknown


def time_msg(stamp_ns: int) -> dict[str, int]:
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    return {"sec": sec, "nanosec": nanosec}


def header_msg(stamp_ns: int, frame_id: str) -> dict[str, Any]:
    return {"stamp": time_msg(stamp_ns), "frame_id": frame_id}


def yaw_of(quaternion: dict[str, Any]) -> float:
    """Yaw (rad) of a geometry_msgs/Quaternion."""
    w, x, y, z = (float(quaternion[k]) for k in ("w", "x", "y", "z"))
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def pose_of(odometry: dict[str, Any]) -> VesselPose:
    """The vessel's pose (map frame) and body velocities from nav_msgs/Odometry."""
    pose = odometry["pose"]["pose"]
    twist = odometry["twist"]["twist"]
    return VesselPose(
        float(pose["position"]["x"]),
        float(pose["position"]["y"]),
        yaw_of(pose["orientation"]),
        float(twist["linear"]["x"]),
        float(twist["angular"]["z"]),
    )


class PoseHistory:
    """The last `capacity` poses (stamp_ns, x, y, yaw): where was the vessel at a stamp?"""

    def __init__(self, capacity: int = 512) -> None:
        self._rows = np.zeros((capacity, 4))
        self._count = 0

    def add(self, stamp_ns: int, pose: VesselPose) -> None:
        k = self._count % len(self._rows)
        self._rows[k] = (stamp_ns / NS_PER_S, pose.x_m, pose.y_m, pose.yaw_rad)
        self._count += 1

    def at(self, stamp_ns: int) -> tuple[float, float, float] | None:
        """(x, y, yaw) of the sample nearest `stamp_ns`, or None before the first."""
        rows = self._rows[: min(self._count, len(self._rows))]
        if not len(rows):
            return None
        k = int(np.argmin(np.abs(rows[:, 0] - stamp_ns / NS_PER_S)))
        return float(rows[k, 1]), float(rows[k, 2]), float(rows[k, 3])


def to_map(points_m: np.ndarray, pose: tuple[float, float, float]) -> np.ndarray:
    """Vessel-frame points (n, 2) into the map frame for a pose (x, y, yaw)."""
    x, y, yaw = pose
    c, s = np.cos(yaw), np.sin(yaw)
    mapped: np.ndarray = points_m @ np.array([[c, s], [-s, c]]) + np.array([x, y])
    return mapped


def grid_obstacles(grid: dict[str, Any]) -> np.ndarray:
    """Centres (n, 2) of the occupied cells of a nav_msgs/OccupancyGrid, in its frame."""
    info = grid["info"]
    width, height = int(info["width"]), int(info["height"])
    cells = np.asarray(grid["data"], dtype=np.int8).reshape(height, width)
    rows, cols = np.nonzero(cells >= OCCUPIED)
    resolution = float(info["resolution"])
    origin = info["origin"]["position"]
    x = float(origin["x"]) + (cols + 0.5) * resolution
    y = float(origin["y"]) + (rows + 0.5) * resolution
    return np.column_stack([x, y])


def box_obstacles(
    boxes: dict[str, Any], offset_xy_m: tuple[float, float], max_z_m: float
) -> np.ndarray:
    """Corners and centre (5 per box) of each LIDAR box's footprint, vessel frame (n, 2)."""
    kept = [b for b in boxes["boxes"] if float(b["min"]["z"]) <= max_z_m]
    if not kept:
        return np.zeros((0, 2))
    lo = np.array([(float(b["min"]["x"]), float(b["min"]["y"])) for b in kept])
    hi = np.array([(float(b["max"]["x"]), float(b["max"]["y"])) for b in kept])
    corners = np.stack(
        [lo, hi, np.column_stack([lo[:, 0], hi[:, 1]]), np.column_stack([hi[:, 0], lo[:, 1]])],
        axis=1,
    )
    points = np.concatenate([corners, ((lo + hi) / 2)[:, None]], axis=1).reshape(-1, 2)
    shifted: np.ndarray = points + np.asarray(offset_xy_m)
    return shifted


def radar_obstacles(detections: dict[str, Any], offset_xy_m: tuple[float, float]) -> np.ndarray:
    """Radar target centres, vessel frame (n, 2)."""
    targets = detections["targets"]
    if not targets:
        return np.zeros((0, 2))
    xy = np.array([(float(t["x_m"]), float(t["y_m"])) for t in targets])
    shifted: np.ndarray = xy + np.asarray(offset_xy_m)
    return shifted


def wrench_stamped_msg(wrench: Wrench, stamp_ns: int) -> dict[str, Any]:
    """geometry_msgs/WrenchStamped: force.x surge (N), torque.z yaw (N m), base_link."""
    return {
        "header": header_msg(stamp_ns, "base_link"),
        "wrench": {
            "force": {"x": wrench.surge_force_n, "y": 0.0, "z": 0.0},
            "torque": {"x": 0.0, "y": 0.0, "z": wrench.yaw_moment_nm},
        },
    }


def path_msg(points_m: np.ndarray, stamp_ns: int) -> dict[str, Any]:
    """nav_msgs/Path of the route in the map frame."""
    header = header_msg(stamp_ns, "map")
    poses = [
        {
            "header": header,
            "pose": {
                "position": {"x": float(x), "y": float(y), "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            },
        }
        for x, y in points_m
    ]
    return {"header": header, "poses": poses}


def target_msg(target_m: tuple[float, float], stamp_ns: int) -> dict[str, Any]:
    """geometry_msgs/PointStamped: the point on the route the vessel steers for."""
    return {
        "header": header_msg(stamp_ns, "map"),
        "point": {"x": target_m[0], "y": target_m[1], "z": 0.0},
    }
