"""How an autopilot run went, from the simulator's ground truth (docs/guidance.md). Pure numpy.

- distance travelled: the length of the odometry track;
- cross-track error: distance of each track point to the route guidance published
  (`/guidance/path`), as RMS;
- clearance: the least distance between the hull (a length x beam rectangle at each odometry
  pose) and the footprint of any scene object (`/sim/ground_truth`), exact for two rectangles
  (the closest pair of points of two convex polygons includes a corner of one of them);
- collisions: the simulator's count (`/sim/status`).

The report reads this off the wire; the tests use the same functions to judge a closed loop.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from clients.report.results import Mission

_CORNERS = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, -1.0], [-1.0, 1.0]])


@dataclass(frozen=True)
class Footprints:
    """Objects as rectangles on the water plane: centres (k, 2), half sizes (k, 2), yaws (k,)."""

    centres_m: np.ndarray
    half_m: np.ndarray
    yaws_rad: np.ndarray

    @classmethod
    def from_markers(cls, markers: Mapping[str, Any]) -> Footprints:
        """From the simulator's /sim/ground_truth MarkerArray (one CUBE per object, map frame)."""
        items = markers["markers"]
        centres = [(m["pose"]["position"]["x"], m["pose"]["position"]["y"]) for m in items]
        half = [(m["scale"]["x"] / 2, m["scale"]["y"] / 2) for m in items]
        q = np.array([[m["pose"]["orientation"][k] for k in "wz"] for m in items]).reshape(-1, 2)
        yaws = 2 * np.arctan2(q[:, 1], q[:, 0])  # yaw-only quaternions
        return cls(np.array(centres).reshape(-1, 2), np.array(half).reshape(-1, 2), yaws)


def _rotate(points: np.ndarray, yaw_rad: np.ndarray) -> np.ndarray:
    """Rotate points (..., 2) by yaw (broadcast against the leading axes)."""
    c, s = np.cos(yaw_rad)[..., None], np.sin(yaw_rad)[..., None]
    x, y = points[..., :1], points[..., 1:]
    rotated: np.ndarray = np.concatenate([c * x - s * y, s * x + c * y], axis=-1)
    return rotated


def _outside_m(
    points: np.ndarray, centres: np.ndarray, half: np.ndarray, yaws: np.ndarray
) -> np.ndarray:
    """Distance of points (m, p, 2) to rectangles (m, k): (m, p, k); 0 inside."""
    local = _rotate(points[:, :, None, :] - centres[:, None], -yaws[:, None])
    gap = np.maximum(np.abs(local) - half[:, None], 0.0)
    distances: np.ndarray = np.hypot(gap[..., 0], gap[..., 1])
    return distances


def hull_clearance_m(
    poses: np.ndarray, length_m: float, beam_m: float, objects: Footprints
) -> np.ndarray:
    """Least hull-to-object distance at each pose (m, 3) = (x, y, yaw): (m,) metres."""
    if len(objects.centres_m) == 0 or len(poses) == 0:
        return np.full(len(poses), np.inf)
    m, k = len(poses), len(objects.centres_m)
    hull_half = np.array([length_m / 2, beam_m / 2])
    hull_corners = _rotate(_CORNERS * hull_half, poses[:, 2:3]) + poses[:, None, :2]  # (m, 4, 2)
    object_corners = _rotate(_CORNERS[None] * objects.half_m[:, None], objects.yaws_rad[:, None])
    object_corners = object_corners + objects.centres_m[:, None]  # (k, 4, 2)
    to_objects = _outside_m(
        hull_corners,
        np.broadcast_to(objects.centres_m, (m, k, 2)),
        np.broadcast_to(objects.half_m, (m, k, 2)),
        np.broadcast_to(objects.yaws_rad, (m, k)),
    ).min(axis=(1, 2))
    corners = np.broadcast_to(object_corners.reshape(1, -1, 2), (m, 4 * k, 2))
    to_hull = _outside_m(
        corners, poses[:, None, :2], np.broadcast_to(hull_half, (m, 1, 2)), poses[:, 2:3]
    ).min(axis=(1, 2))
    clearance: np.ndarray = np.minimum(to_objects, to_hull)
    return clearance


def track_length_m(xy_m: np.ndarray) -> float:
    """Length of a track (n, 2)."""
    steps = np.diff(np.asarray(xy_m, dtype=np.float64), axis=0)
    return float(np.hypot(steps[:, 0], steps[:, 1]).sum())


def route_distance_m(route_m: np.ndarray, xy_m: np.ndarray) -> np.ndarray:
    """Distance of each point (m, 2) to the polyline (n, 2): (m,) metres."""
    a = np.asarray(route_m, dtype=np.float64)
    d = np.diff(a, axis=0)
    p = np.asarray(xy_m, dtype=np.float64)[:, None, :] - a[None, :-1]
    t = np.clip((p * d).sum(axis=2) / np.maximum((d * d).sum(axis=1), 1e-12), 0.0, 1.0)
    gap = p - t[..., None] * d[None]
    distances: np.ndarray = np.hypot(gap[..., 0], gap[..., 1]).min(axis=1)
    return distances


@dataclass(frozen=True)
class AutopilotSeen:
    """What a window saw of an autopilot run: odometry (in the window), the route guidance
    published, the scene's objects, the simulator's /sim/status messages and its hull size."""

    odometry: Sequence[Mapping[str, Any]] = ()
    path: Mapping[str, Any] | None = None
    ground_truth: Mapping[str, Any] | None = None
    status: Sequence[Mapping[str, Any]] = ()
    hull_m: tuple[float, float] = (7.0, 2.5)  # the simulator's [vessel] length_m, beam_m


def poses_of(odometry: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """(m, 3) x, y, yaw of nav_msgs/Odometry messages."""
    rows = [
        (
            p["position"]["x"],
            p["position"]["y"],
            2 * np.arctan2(p["orientation"]["z"], p["orientation"]["w"]),
        )
        for p in (m["pose"]["pose"] for m in odometry)
    ]
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def collisions_in(status: Sequence[Mapping[str, Any]]) -> int:
    """Collisions the simulator counted between the first and last /sim/status."""
    counts = [
        int(v["value"])
        for msg in status
        for v in msg["status"][0]["values"]
        if v["key"] == "collisions"
    ]
    return counts[-1] - counts[0] if len(counts) > 1 else 0


def mission(seen: AutopilotSeen) -> Mission | None:
    """The mission figures, or None without odometry."""
    poses = poses_of(seen.odometry)
    if len(poses) < 2:
        return None
    cross = math.nan
    if seen.path is not None and len(seen.path["poses"]) >= 2:
        route = np.array(
            [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in seen.path["poses"]]
        )
        cross = float(np.sqrt(np.mean(route_distance_m(route, poses[:, :2]) ** 2)))
    clearance = math.nan
    if seen.ground_truth is not None:
        objects = Footprints.from_markers(seen.ground_truth)
        clearance = float(hull_clearance_m(poses, *seen.hull_m, objects).min())
    return Mission(track_length_m(poses[:, :2]), cross, clearance, collisions_in(seen.status))
