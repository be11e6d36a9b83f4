"""``sensor_msgs/msg/PointCloud2`` <-> numpy: one layout, packed in one copy, viewed in none.

Riverbridge's clouds are unordered (``height`` 1), little-endian, with float32 fields placed
one after another from offset 0: x, y, z and (unless a profile drops it) intensity. `pack`
builds such a cloud; `view_points` reads any cloud whose requested fields are consecutive float32,
whatever its ``point_step`` (padding or further fields make the view strided).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from schemas.message import ns_to_stamp

FLOAT32 = 7  # sensor_msgs/msg/PointField.FLOAT32
XYZI = ("x", "y", "z", "intensity")
XYZ = XYZI[:3]
# Named layouts, as configuration spells them (simulator [lidar] point_fields).
LAYOUTS: Mapping[str, tuple[str, ...]] = {"xyzi": XYZI, "xyz": XYZ}


class PointCloudLayoutError(ValueError):
    """The cloud does not carry the requested fields as consecutive little-endian float32."""


def pack_points(
    points: np.ndarray,
    stamp_ns: int,
    frame_id: str,
    fields: Sequence[str] = XYZI,
    *,
    is_dense: bool = True,
) -> dict[str, Any]:
    """Canonical PointCloud2 of the first ``len(fields)`` columns of ``points``.

    points : (n, >= len(fields)) float32 (other dtypes are converted), any strides; the
    columns become ``data`` in one copy (two when columns are dropped).
    is_dense : the caller's promise that every point is finite (ROS's meaning).
    """
    points = np.asarray(points)
    width = len(fields)
    if points.ndim != 2 or points.shape[1] < width:
        raise ValueError(
            f"points must be (n, >= {width}) for fields {tuple(fields)}, got {points.shape}"
        )
    data = np.ascontiguousarray(points[:, :width], dtype="<f4")
    step, count = 4 * width, points.shape[0]
    return {
        "header": {"stamp": ns_to_stamp(stamp_ns), "frame_id": frame_id},
        "height": 1,
        "width": count,
        "fields": [
            {"name": name, "offset": 4 * k, "datatype": FLOAT32, "count": 1}
            for k, name in enumerate(fields)
        ],
        "is_bigendian": False,
        "point_step": step,
        "row_step": step * count,
        "data": data.tobytes(),
        "is_dense": bool(is_dense),
    }


def view_points(msg: Mapping[str, Any], fields: Sequence[str] = XYZI) -> np.ndarray:
    """(n, len(fields)) float32 view of a PointCloud2's ``fields``, sharing ``msg["data"]``.

    Read-only when ``data`` is ``bytes``; n = width * height. Raises `PointCloudLayoutError`
    naming what is wrong (a missing field, a gap or another type, big-endian, short data).
    """
    by_name = {f["name"]: f for f in msg["fields"]}
    missing = [name for name in fields if name not in by_name]
    if missing:
        raise PointCloudLayoutError(f"PointCloud2 lacks fields {missing}")
    offset = int(by_name[fields[0]]["offset"])
    for k, name in enumerate(fields):
        field = by_name[name]
        if field["datatype"] != FLOAT32 or int(field["offset"]) != offset + 4 * k:
            raise PointCloudLayoutError(f"{', '.join(fields)} must be consecutive float32 fields")
    if msg["is_bigendian"]:
        raise PointCloudLayoutError("big-endian PointCloud2 is not supported")
    step = int(msg["point_step"])
    count = int(msg["width"]) * int(msg["height"])
    data = msg["data"]
    if count * step > len(data):
        raise PointCloudLayoutError(f"data holds {len(data)} B, need {count * step} B")
    return np.ndarray(
        shape=(count, len(fields)),
        dtype="<f4",
        buffer=np.frombuffer(data, dtype=np.uint8),
        offset=offset,
        strides=(step, 4),
    )
