"""Obstacle map: LIDAR boxes and radar detections fused into a vessel-centred grid.

The thesis shows LIDAR boxes and radar detections together from above (figure 21); here the
same picture is data, a ``nav_msgs/msg/OccupancyGrid`` in the vessel frame: 100 where a box
footprint or a radar detection falls, 0 inside some sensor's range, -1 (unknown) elsewhere.
Grid rows run along +y, columns along +x, the vessel at the centre. Sensor offsets are
translations in the vessel frame (sensors are mounted axis-aligned with the hull).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from navigation.boxes import Boxes
from navigation.config import FusionConfig
from navigation.messages import f32, header_msg, pose_msg, time_msg

FREE = 0
OCCUPIED = 100
UNKNOWN = -1


@dataclass(frozen=True)
class GridGeometry:
    """A square grid of ``cells`` x ``cells`` of ``resolution_m``, centred on the vessel."""

    cells: int
    resolution_m: float

    @classmethod
    def of(cls, config: FusionConfig) -> GridGeometry:
        return cls(max(1, round(config.size_m / config.resolution_m)), config.resolution_m)

    @property
    def origin_m(self) -> float:
        """x and y of the grid's lower-left corner in the vessel frame."""
        return -0.5 * self.cells * self.resolution_m

    def index(self, coord_m: np.ndarray) -> np.ndarray:
        """Cell index of coordinates (any shape), unclipped: may fall outside the grid."""
        return np.floor((np.asarray(coord_m) - self.origin_m) / self.resolution_m).astype(np.intp)

    def centres_m(self) -> np.ndarray:
        """(cells,) coordinate of each row's or column's centre."""
        return self.origin_m + (np.arange(self.cells) + 0.5) * self.resolution_m


def coverage(
    geometry: GridGeometry, origins_xy_m: list[tuple[float, float]], ranges_m: list[float]
) -> np.ndarray:
    """Cells whose centre lies within range of at least one sensor: (cells, cells) bool."""
    centres = geometry.centres_m()
    covered = np.zeros((geometry.cells, geometry.cells), dtype=bool)
    for (ox, oy), range_m in zip(origins_xy_m, ranges_m, strict=True):  # one pass per sensor
        dx2 = (centres - ox) ** 2
        dy2 = (centres - oy) ** 2
        covered |= dy2[:, None] + dx2[None, :] <= range_m**2
    return covered


def mark_boxes(
    grid: np.ndarray, geometry: GridGeometry, lo_xy: np.ndarray, hi_xy: np.ndarray
) -> None:
    """Set every cell a box footprint touches to OCCUPIED. lo_xy, hi_xy : (m, 2) metres."""
    if lo_xy.shape[0] == 0:
        return
    c0, r0 = geometry.index(lo_xy).T
    c1, r1 = geometry.index(hi_xy).T
    span = int(max((c1 - c0).max(), (r1 - r0).max())) + 1
    step = np.arange(span)
    cols = c0[:, None, None] + step[None, None, :]  # (m, 1, span)
    rows = r0[:, None, None] + step[None, :, None]  # (m, span, 1)
    inside = (cols <= c1[:, None, None]) & (rows <= r1[:, None, None])
    inside &= (cols >= 0) & (cols < geometry.cells) & (rows >= 0) & (rows < geometry.cells)
    rows_b, cols_b = np.broadcast_arrays(rows, cols)
    grid[rows_b[inside], cols_b[inside]] = OCCUPIED


def mark_points(grid: np.ndarray, geometry: GridGeometry, xy_m: np.ndarray) -> None:
    """Set the cells holding points xy_m : (k, 2) metres to OCCUPIED."""
    col, row = geometry.index(xy_m).T
    ok = (col >= 0) & (col < geometry.cells) & (row >= 0) & (row < geometry.cells)
    grid[row[ok], col[ok]] = OCCUPIED


def obstacle_grid(
    boxes: Boxes | None, radar_xy_m: np.ndarray | None, config: FusionConfig
) -> np.ndarray:
    """Fuse the latest LIDAR boxes (lidar frame) and radar detections (radar frame, (k, 2)).

    None means the sensor has not reported, so its range stays unknown.
    Returns (cells, cells) int8, row-major as OccupancyGrid wants it.
    """
    geometry = GridGeometry.of(config)
    origins, ranges = [], []
    if boxes is not None:
        origins.append(config.lidar_offset_xy_m)
        ranges.append(config.lidar_range_m)
    if radar_xy_m is not None:
        origins.append(config.radar_offset_xy_m)
        ranges.append(config.radar_range_m)
    grid = np.where(coverage(geometry, origins, ranges), FREE, UNKNOWN).astype(np.int8)
    if boxes is not None and len(boxes):
        low_enough = boxes.min_xyz[:, 2] <= config.max_obstacle_z_m
        offset = np.asarray(config.lidar_offset_xy_m)
        lo = boxes.min_xyz[low_enough, :2] + offset
        hi = boxes.max_xyz[low_enough, :2] + offset
        mark_boxes(grid, geometry, lo, hi)
    if radar_xy_m is not None and radar_xy_m.shape[0]:
        mark_points(grid, geometry, np.asarray(radar_xy_m) + np.asarray(config.radar_offset_xy_m))
    return grid


def occupancy_grid_msg(grid: np.ndarray, stamp_ns: int, config: FusionConfig) -> dict[str, Any]:
    """Canonical ``nav_msgs/msg/OccupancyGrid``; ``data`` is the flattened int8 grid."""
    geometry = GridGeometry.of(config)
    return {
        "header": header_msg(stamp_ns, config.frame_id),
        "info": {
            "map_load_time": time_msg(stamp_ns),
            "resolution": f32(geometry.resolution_m),
            "width": geometry.cells,
            "height": geometry.cells,
            "origin": pose_msg(geometry.origin_m, geometry.origin_m, 0.0),
        },
        "data": np.ascontiguousarray(grid, dtype=np.int8).reshape(-1),
    }
