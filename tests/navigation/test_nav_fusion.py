"""Occupancy grid fused from LIDAR boxes and radar detections."""

from __future__ import annotations

import numpy as np

from navigation.boxes import Boxes
from navigation.config import FusionConfig
from navigation.fusion import OCCUPIED, UNKNOWN, GridGeometry, obstacle_grid, occupancy_grid_msg

CONFIG = FusionConfig(size_m=100.0, resolution_m=1.0, lidar_range_m=30.0, radar_range_m=40.0)


def boxes(*corners) -> Boxes:
    if not corners:
        return Boxes.empty()
    lo = np.array([c[0] for c in corners], np.float32)
    hi = np.array([c[1] for c in corners], np.float32)
    n = len(corners)
    return Boxes(lo, hi, np.arange(n, dtype=np.int32), np.ones(n, np.uint32))


def cell(x_m: float, y_m: float) -> tuple[int, int]:
    geometry = GridGeometry.of(CONFIG)
    col, row = geometry.index(np.array([x_m, y_m]))
    return int(row), int(col)


def test_box_footprints_and_detections_are_occupied(check_canonical):
    lidar = boxes(((10.2, 5.2, -1.0), (12.8, 6.8, 1.0)), ((-20.5, -3.5, 0.0), (-20.1, -3.1, 2.0)))
    radar_xy = np.array([[0.0, -35.5], [25.5, 25.5]], np.float32)
    grid = obstacle_grid(lidar, radar_xy, CONFIG)
    assert grid.shape == (100, 100) and grid.dtype == np.int8
    for x in (10.5, 11.5, 12.5):
        for y in (5.5, 6.5):
            assert grid[cell(x, y)] == OCCUPIED
    assert grid[cell(13.5, 5.5)] == 0 and grid[cell(9.5, 5.5)] == 0
    assert grid[cell(-20.3, -3.3)] == OCCUPIED
    assert grid[cell(0.0, -35.5)] == OCCUPIED and grid[cell(25.5, 25.5)] == OCCUPIED
    assert int((grid == OCCUPIED).sum()) == 6 + 1 + 2
    assert grid[cell(45.0, 45.0)] == UNKNOWN  # beyond every sensor's range
    msg = occupancy_grid_msg(grid, 5_000_000_000, CONFIG)
    check_canonical("nav_msgs/msg/OccupancyGrid", msg)
    assert msg["info"]["origin"]["position"]["x"] == -50.0
    assert msg["data"][cell(10.5, 5.5)[0] * 100 + cell(10.5, 5.5)[1]] == OCCUPIED


def test_a_silent_sensor_leaves_its_range_unknown():
    only_lidar = obstacle_grid(boxes(), None, CONFIG)
    assert only_lidar[cell(0.5, 35.5)] == UNKNOWN  # radar range only
    assert only_lidar[cell(0.5, 25.5)] == 0
    assert (obstacle_grid(None, None, CONFIG) == UNKNOWN).all()


def test_overhead_boxes_and_offsets():
    config = CONFIG.model_copy(update={"lidar_offset_xy_m": (2.0, 0.0), "max_obstacle_z_m": 5.0})
    bridge = ((10.2, 0.2, 8.0), (10.8, 0.8, 9.0))
    buoy = ((10.2, 2.2, -1.0), (10.8, 2.8, 0.5))
    grid = obstacle_grid(boxes(bridge, buoy), None, config)
    assert grid[cell(12.5, 0.5)] == 0  # above the hull: not an obstacle
    assert grid[cell(12.5, 2.5)] == OCCUPIED  # shifted by the sensor offset
    assert grid[cell(10.5, 2.5)] == 0


def test_boxes_partly_outside_the_grid_are_clipped():
    grid = obstacle_grid(
        boxes(((48.2, -1.0, 0.0), (51.0, 1.0, 1.0))),
        None,
        CONFIG.model_copy(update={"lidar_range_m": 80.0}),
    )
    assert grid[cell(49.5, 0.5)] == OCCUPIED
