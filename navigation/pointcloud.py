"""``sensor_msgs/msg/PointCloud2`` <-> (n, 4) float32 arrays without copying the payload."""

from __future__ import annotations

from typing import Any

import numpy as np

from navigation.messages import header_msg

FLOAT32 = 7  # sensor_msgs/msg/PointField.FLOAT32
XYZI_FIELDS = ("x", "y", "z", "intensity")


class PointCloudLayoutError(ValueError):
    """The cloud does not carry x, y, z (, intensity) as consecutive little-endian float32."""


def xyzi_view(msg: dict[str, Any]) -> np.ndarray:
    """View a canonical PointCloud2 as points : (n, 4) float32 [x, y, z, intensity].

    The view shares memory with ``msg["data"]`` (read-only for ``bytes``); a wider
    ``point_step`` (padding, extra fields after intensity) becomes a strided view.
    """
    return _float_view(msg, XYZI_FIELDS)


def xyz_view(msg: dict[str, Any]) -> np.ndarray:
    """View a canonical PointCloud2 as points : (n, 3) float32 [x, y, z], with or without
    an intensity field (the thesis's clouds carried x, y, z alone, 3.5.2)."""
    return _float_view(msg, XYZI_FIELDS[:3])


def _float_view(msg: dict[str, Any], names: tuple[str, ...]) -> np.ndarray:
    """(n, len(names)) float32 view of consecutive float32 fields ``names``."""
    fields = {f["name"]: f for f in msg["fields"]}
    missing = [name for name in names if name not in fields]
    if missing:
        raise PointCloudLayoutError(f"PointCloud2 lacks fields {missing}")
    offset = int(fields["x"]["offset"])
    for i, name in enumerate(names):
        field = fields[name]
        if field["datatype"] != FLOAT32 or int(field["offset"]) != offset + 4 * i:
            raise PointCloudLayoutError(f"{', '.join(names)} must be consecutive float32 fields")
    if msg["is_bigendian"]:
        raise PointCloudLayoutError("big-endian PointCloud2 is not supported")
    step = int(msg["point_step"])
    count = int(msg["width"]) * int(msg["height"])
    data = msg["data"]
    if count * step > len(data):
        raise PointCloudLayoutError(f"data holds {len(data)} B, need {count * step} B")
    buffer = np.frombuffer(data, dtype=np.uint8)
    return np.ndarray(
        shape=(count, len(names)), dtype="<f4", buffer=buffer, offset=offset, strides=(step, 4)
    )


def pointcloud2_msg(points: np.ndarray, stamp_ns: int, frame_id: str) -> dict[str, Any]:
    """Canonical PointCloud2 from points : (n, 4) float32 [x, y, z, intensity]."""
    packed = np.ascontiguousarray(points, dtype="<f4")
    if packed.ndim != 2 or packed.shape[1] != 4:
        raise ValueError(f"points must be (n, 4), got {packed.shape}")
    return {
        "header": header_msg(stamp_ns, frame_id),
        "height": 1,
        "width": packed.shape[0],
        "fields": [
            {"name": name, "offset": 4 * i, "datatype": FLOAT32, "count": 1}
            for i, name in enumerate(XYZI_FIELDS)
        ],
        "is_bigendian": False,
        "point_step": 16,
        "row_step": 16 * packed.shape[0],
        "data": packed.tobytes(),
        "is_dense": bool(np.isfinite(packed[:, :3]).all()),
    }
