"""`visualization_msgs/msg/Marker` in canonical form: the navigation service's LIDAR boxes and
the simulator's ground truth both draw cubes, and every field they do not set is at its
default, in the registry's field order (so every encoding of a marker is the same)."""

from __future__ import annotations

from typing import Any

from schemas.values import Message

MARKER_ADD = 0  # visualization_msgs/msg/Marker.ADD
MARKER_CUBE = 1  # visualization_msgs/msg/Marker.CUBE
MARKER_DELETEALL = 3  # visualization_msgs/msg/Marker.DELETEALL


def marker_msg(
    header: Message,
    ns: str,
    marker_id: int,
    marker_type: int,
    action: int,
    *,
    pose: Message | None = None,
    scale: Message | None = None,
    color: Message | None = None,
) -> dict[str, Any]:
    """A Marker with the given header, namespace, id, type and action; pose (identity),
    scale and color (zero) as given, every other field at its default."""
    return {
        "header": header,
        "ns": ns,
        "id": marker_id,
        "type": marker_type,
        "action": action,
        "pose": pose
        or {
            "position": {"x": 0.0, "y": 0.0, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        },
        "scale": scale or {"x": 0.0, "y": 0.0, "z": 0.0},
        "color": color or {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.0},
        "lifetime": {"sec": 0, "nanosec": 0},
        "frame_locked": False,
        "points": [],
        "colors": [],
        "texture_resource": "",
        "texture": {
            "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
            "format": "",
            "data": b"",
        },
        "uv_coordinates": [],
        "text": "",
        "mesh_resource": "",
        "mesh_file": {"filename": "", "data": b""},
        "mesh_use_embedded_materials": False,
    }
