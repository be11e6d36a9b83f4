"""LIDAR boxes as ``riverbridge_msgs/msg/BoxArray`` and ``visualization_msgs/msg/MarkerArray``.

One Python dict per box is built here: boxes number in the hundreds, not per point.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navigation.boxes import Boxes
from navigation.messages import cluster_colors, header_msg, point_msg
from schemas.markers import MARKER_ADD, MARKER_CUBE, MARKER_DELETEALL, marker_msg

MARKER_ALPHA = 0.5  # see-through, so the cloud stays visible under the boxes


def box_array_msg(
    boxes: Boxes, stamp_ns: int, frame_id: str, method: str, num_clusters: int
) -> dict[str, Any]:
    """Canonical ``riverbridge_msgs/msg/BoxArray``."""
    lo = boxes.min_xyz.tolist()
    hi = boxes.max_xyz.tolist()
    items = [
        {
            "cluster_id": cid,
            "min": point_msg(*a),
            "max": point_msg(*b),
            "num_points": count,
        }
        for cid, a, b, count in zip(
            boxes.cluster_id.tolist(), lo, hi, boxes.num_points.tolist(), strict=True
        )
    ]
    return {
        "header": header_msg(stamp_ns, frame_id),
        "method": method,
        "num_clusters": int(num_clusters),
        "boxes": items,
    }


def _marker(
    stamp_ns: int, frame_id: str, ns: str, marker_id: int, marker_type: int, action: int
) -> dict[str, Any]:
    """A canonical ``visualization_msgs/msg/Marker`` with every field at its default."""
    return marker_msg(header_msg(stamp_ns, frame_id), ns, marker_id, marker_type, action)


def marker_array_msg(
    boxes: Boxes, stamp_ns: int, frame_id: str, ns: str = "lidar_boxes"
) -> dict[str, Any]:
    """Canonical ``visualization_msgs/msg/MarkerArray``: DELETEALL, then one CUBE per box.

    The leading DELETEALL clears the previous scan's boxes, so a scan with fewer boxes leaves
    no stale ones behind. Colours follow the cluster id.
    """
    markers = [_marker(stamp_ns, frame_id, ns, 0, MARKER_CUBE, MARKER_DELETEALL)]
    centers = boxes.center_xyz.tolist()
    sizes = boxes.size_xyz.tolist()
    colors = cluster_colors(boxes.cluster_id).tolist() if len(boxes) else []
    for i, (center, size, rgb) in enumerate(zip(centers, sizes, colors, strict=True)):
        marker = _marker(stamp_ns, frame_id, ns, i, MARKER_CUBE, MARKER_ADD)
        marker["pose"]["position"] = point_msg(*center)
        # RViz refuses zero scale; a flat box (one point thick) gets 1 cm.
        marker["scale"] = dict(zip("xyz", np.maximum(size, 0.01).tolist(), strict=True))
        marker["color"] = {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": MARKER_ALPHA}
        markers.append(marker)
    return {"markers": markers}
