"""Small helpers shared by the message builders (canonical form, see docs/messages.md)."""

from __future__ import annotations

from typing import Any

import numpy as np

NS_PER_S = 1_000_000_000


def time_msg(stamp_ns: int) -> dict[str, int]:
    """``builtin_interfaces/msg/Time`` from integer nanoseconds."""
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    return {"sec": sec, "nanosec": nanosec}


def stamp_ns_of(header: dict[str, Any]) -> int:
    """Nanoseconds of a canonical ``std_msgs/msg/Header``."""
    stamp = header["stamp"]
    return int(stamp["sec"]) * NS_PER_S + int(stamp["nanosec"])


def f32(value: float) -> float:
    """A float rounded to float32, as a float32 message field stores (and returns) it."""
    return float(np.float32(value))


def header_msg(stamp_ns: int, frame_id: str) -> dict[str, Any]:
    """``std_msgs/msg/Header``."""
    return {"stamp": time_msg(stamp_ns), "frame_id": frame_id}


def point_msg(x: float, y: float, z: float) -> dict[str, float]:
    """``geometry_msgs/msg/Point``."""
    return {"x": float(x), "y": float(y), "z": float(z)}


def pose_msg(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict[str, Any]:
    """``geometry_msgs/msg/Pose`` with identity orientation."""
    return {
        "position": point_msg(x, y, z),
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
    }


def cluster_colors(cluster_ids: np.ndarray) -> np.ndarray:
    """Distinct, stable RGB colours per cluster id: (m,) int -> (m, 3) float32 in [0, 1].

    Golden-ratio hue steps keep neighbouring ids apart; saturation and value are fixed.
    """
    hue = (np.asarray(cluster_ids, dtype=np.float64) * 0.618033988749895) % 1.0
    sector = hue * 6.0
    rgb = np.clip(np.abs((sector[:, None] + [0.0, 4.0, 2.0]) % 6.0 - 3.0) - 1.0, 0.0, 1.0)
    return (0.25 + 0.75 * rgb).astype(np.float32)  # ColorRGBA holds float32
