"""Per-sensor handlers: one input message in, output messages out (no I/O, no clock).

The edge (``navigation.node``) runs each handler on its sensor's worker thread and publishes
what it returns; keeping them here makes the whole message path testable without a bridge.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navigation.boxes import Boxes, refine_boxes
from navigation.camera import extract_lines, line_array_msg
from navigation.cfar import CfarDetector
from navigation.config import LidarConfig, NavigationConfig
from navigation.fusion import obstacle_grid, occupancy_grid_msg
from navigation.lidar import NOISE, LidarResult, cluster_obstacles, obstacle_points
from navigation.lidar_messages import box_array_msg, marker_array_msg
from navigation.messages import stamp_ns_of
from navigation.pointcloud import xyzi_view
from navigation.radar import PolarGeometry, detect, detection_array_msg, radar_power

TOPIC_BOXES = "/nav/boxes"
TOPIC_MARKERS = "/nav/markers"
TOPIC_RADAR = "/nav/radar_detections"
TOPIC_LINES = "/nav/lines"
TOPIC_MAP = "/nav/obstacle_map"
TOPIC_DIAGNOSTICS = "/nav/diagnostics"

OUTPUT_TYPES = {
    TOPIC_BOXES: "riverbridge_msgs/msg/BoxArray",
    TOPIC_MARKERS: "visualization_msgs/msg/MarkerArray",
    TOPIC_RADAR: "riverbridge_msgs/msg/RadarDetectionArray",
    TOPIC_LINES: "riverbridge_msgs/msg/ImageLineArray",
    TOPIC_MAP: "nav_msgs/msg/OccupancyGrid",
    TOPIC_DIAGNOSTICS: "diagnostic_msgs/msg/DiagnosticArray",
}

Outputs = list[tuple[str, dict[str, Any]]]
# Sub-step name -> (start_ns, end_ns) wall clock, filled by a handler for stage tracing
StepTimes = dict[str, tuple[int, int]]


@dataclass
class LatestObstacles:
    """The newest LIDAR boxes and radar detections for the fusion timer (None = not seen).

    Written by the sensor threads, read by the fusion step; a lock keeps each pair coherent.
    """

    boxes: Boxes | None = None
    radar_xy_m: np.ndarray | None = None
    stamp_ns: int = 0
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def set_boxes(self, boxes: Boxes, stamp_ns: int) -> None:
        with self._lock:
            self.boxes = boxes
            self.stamp_ns = max(self.stamp_ns, stamp_ns)

    def set_radar(self, xy_m: np.ndarray, stamp_ns: int) -> None:
        with self._lock:
            self.radar_xy_m = xy_m
            self.stamp_ns = max(self.stamp_ns, stamp_ns)

    def snapshot(self) -> tuple[Boxes | None, np.ndarray | None, int]:
        with self._lock:
            return self.boxes, self.radar_xy_m, self.stamp_ns


class Processors:
    """The navigation service's handlers for one configuration."""

    def __init__(self, config: NavigationConfig) -> None:
        self.config = config
        self.latest = LatestObstacles()
        self._detectors: dict[int, CfarDetector] = {}  # by row length; rows rarely change
        self.lidar_steps: StepTimes = {}  # sub-step spans of the last scan (see `lidar`)

    def lidar(self, msg: dict[str, Any]) -> Outputs:
        """PointCloud2 -> BoxArray and MarkerArray (thesis 3.5.3). Leaves the wall-clock
        spans of ``filter``, ``dbscan`` and ``boxes`` (the thesis's 29 ms and 186 ms) in
        ``lidar_steps`` for stage tracing (one LIDAR thread, so read it after the call)."""
        stamp_ns, frame_id = stamp_ns_of(msg["header"]), msg["header"]["frame_id"]
        steps: StepTimes = {}
        result = timed_process_scan(xyzi_view(msg), self.config.lidar, steps)
        self.lidar_steps = steps
        self.latest.set_boxes(result.boxes, stamp_ns)
        method = self.config.lidar.method
        boxes = box_array_msg(result.boxes, stamp_ns, frame_id, method, result.num_clusters)
        return [
            (TOPIC_BOXES, boxes),
            (TOPIC_MARKERS, marker_array_msg(result.boxes, stamp_ns, frame_id)),
        ]

    def radar(self, msg: dict[str, Any]) -> Outputs:
        """RadarImage -> RadarDetectionArray (thesis 3.5.3, SOCA-CFAR by default)."""
        power = radar_power(msg)
        cells = power.shape[1]
        if cells not in self._detectors:
            self._detectors[cells] = CfarDetector.from_config(self.config.cfar, num_cells=cells)
        detector = self._detectors[cells]
        found = detect(power, PolarGeometry.of(msg), detector)
        stamp_ns = stamp_ns_of(msg["header"])
        self.latest.set_radar(np.column_stack([found.x_m, found.y_m]), stamp_ns)
        frame_id = msg["header"]["frame_id"]
        return [(TOPIC_RADAR, detection_array_msg(found, stamp_ns, frame_id, detector))]

    def camera(self, msg: dict[str, Any]) -> Outputs:
        """CompressedImage -> ImageLineArray (thesis table 4.6)."""
        config = self.config.camera
        lines, width, height = extract_lines(msg["data"], config)
        stamp_ns, frame_id = stamp_ns_of(msg["header"]), msg["header"]["frame_id"]
        out = line_array_msg(lines, width, height, stamp_ns, frame_id, config.probabilistic)
        return [(TOPIC_LINES, out)]

    def obstacle_map(self) -> Outputs:
        """The fused OccupancyGrid of the latest obstacles (thesis figure 21 as data)."""
        boxes, radar_xy_m, stamp_ns = self.latest.snapshot()
        grid = obstacle_grid(boxes, radar_xy_m, self.config.fusion)
        return [(TOPIC_MAP, occupancy_grid_msg(grid, stamp_ns, self.config.fusion))]


def timed_process_scan(points: np.ndarray, config: LidarConfig,
                       steps: StepTimes) -> LidarResult:
    """`navigation.lidar.process_scan`, step by step, with each step's wall-clock span put
    in ``steps``. points : (n, >=3) float32, sensor frame, metres."""
    t0 = time.time_ns()
    keep, water_z = obstacle_points(points, config)
    index = np.flatnonzero(keep)
    xyz = np.ascontiguousarray(points[index, :3])
    t1 = time.time_ns()
    obstacle_labels, samples = cluster_obstacles(xyz, config)
    t2 = time.time_ns()
    boxes = refine_boxes(xyz, obstacle_labels, config.box_max_size_m, config.shrink_boxes)
    t3 = time.time_ns()
    steps.update(filter=(t0, t1), dbscan=(t1, t2), boxes=(t2, t3))
    labels = np.full(points.shape[0], NOISE, dtype=np.int32)
    labels[index] = obstacle_labels
    num_clusters = int(np.unique(obstacle_labels[obstacle_labels >= 0]).size)
    return LidarResult(labels, keep, boxes, num_clusters, samples, water_z)
