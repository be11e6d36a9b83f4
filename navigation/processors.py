"""Per-sensor handlers: one input message in, output messages out (no I/O).

The edge (``navigation.node``) runs each handler on its sensor's worker thread and publishes
what it returns; keeping them here makes the whole message path testable without a bridge.
The LIDAR handler hands the points to a ``LidarWorker`` (by default a worker process, see
``navigation.lidar_worker``); ``start`` and ``close`` bracket its life.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navigation.boxes import Boxes
from navigation.camera import extract_lines, line_array_msg
from navigation.cfar import CfarDetector
from navigation.config import NavigationConfig
from navigation.fusion import obstacle_grid, occupancy_grid_msg
from navigation.lidar import StepTimes
from navigation.lidar_messages import box_array_msg, marker_array_msg
from navigation.lidar_worker import LidarWorker, lidar_worker_for
from navigation.messages import stamp_ns_of
from navigation.radar import PolarGeometry, detect, detection_array_msg, radar_power
from schemas.catalogue import TOPICS, published_by
from schemas.pointcloud import XYZ, view_points

TOPIC_BOXES = TOPICS["boxes"].name
TOPIC_MARKERS = TOPICS["markers"].name
TOPIC_RADAR = TOPICS["radar_detections"].name
TOPIC_LINES = TOPICS["lines"].name
TOPIC_MAP = TOPICS["obstacle_map"].name
TOPIC_DIAGNOSTICS = TOPICS["diagnostics"].name
# Everything navigation publishes (schemas.catalogue), advertised at start.
OUTPUT_TYPES = {t.name: t.type for t in published_by("navigation")}

Outputs = list[tuple[str, dict[str, Any]]]


@dataclass(frozen=True)
class Handled:
    """What a handler made of one message: the outputs to publish, and the wall-clock spans
    of its steps (traced as ``process.<step>``; empty for a handler that times none)."""

    outputs: Outputs
    steps: StepTimes = field(default_factory=dict)


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

    def __init__(self, config: NavigationConfig, lidar_worker: LidarWorker | None = None) -> None:
        """``lidar_worker`` defaults to the one ``config.lidar.worker`` names."""
        self.config = config
        self.latest = LatestObstacles()
        self._detector = CfarDetector.from_config(config.cfar)
        self._fitting_shapes: set[tuple[int, int]] = set()  # image shapes the window fits
        self.lidar_worker = lidar_worker or lidar_worker_for(config.lidar)

    def start(self) -> None:
        """Start (and warm up) the LIDAR worker; blocks for its start-up, seconds."""
        self.lidar_worker.start()

    def close(self) -> None:
        """Stop the LIDAR worker; waits for a scan in progress."""
        self.lidar_worker.close()

    def handlers(self) -> dict[str, Callable[[dict[str, Any]], Handled]]:
        """The handler of each input topic, by catalogue key (the node runs each on a thread
        of its own)."""
        return {"lidar": self.lidar, "radar": self.radar, "camera": self.camera}

    def lidar(self, msg: dict[str, Any]) -> Handled:
        """PointCloud2 -> BoxArray and MarkerArray (thesis 3.5.3), with the spans of the
        pipeline's ``filter``, ``dbscan`` and ``boxes`` (the thesis's 29 ms and 186 ms)."""
        stamp_ns, frame_id = stamp_ns_of(msg["header"]), msg["header"]["frame_id"]
        result = self.lidar_worker(view_points(msg, XYZ))
        self.latest.set_boxes(result.boxes, stamp_ns)
        method = self.config.lidar.method
        boxes = box_array_msg(result.boxes, stamp_ns, frame_id, method, result.num_clusters)
        return Handled(
            [
                (TOPIC_BOXES, boxes),
                (TOPIC_MARKERS, marker_array_msg(result.boxes, stamp_ns, frame_id)),
            ],
            result.steps,
        )

    def radar(self, msg: dict[str, Any]) -> Handled:
        """RadarImage -> RadarDetectionArray (thesis 3.5.3, SOCA-CFAR by default): detected
        cells grouped into targets. The obstacle map takes the targets' cells (so a long
        target such as a bank keeps its extent). Raises ``CfarWindowError`` (naming the
        fields) when the configured window does not fit the image."""
        power = radar_power(msg)
        detector = self._detector
        if power.shape not in self._fitting_shapes:
            detector.check_fits(*power.shape)
            self._fitting_shapes.add(power.shape)
        found, targets = detect(power, PolarGeometry.of(msg), detector)
        stamp_ns = stamp_ns_of(msg["header"])
        in_target = found.target >= 0
        self.latest.set_radar(
            np.column_stack([found.x_m[in_target], found.y_m[in_target]]), stamp_ns
        )
        frame_id = msg["header"]["frame_id"]
        return Handled(
            [(TOPIC_RADAR, detection_array_msg(found, targets, stamp_ns, frame_id, detector))]
        )

    def camera(self, msg: dict[str, Any]) -> Handled:
        """CompressedImage -> ImageLineArray (thesis table 4.6)."""
        config = self.config.camera
        lines, width, height = extract_lines(msg["data"], config)
        stamp_ns, frame_id = stamp_ns_of(msg["header"]), msg["header"]["frame_id"]
        out = line_array_msg(lines, width, height, stamp_ns, frame_id, config.probabilistic)
        return Handled([(TOPIC_LINES, out)])

    def obstacle_map(self) -> Outputs:
        """The fused OccupancyGrid of the latest obstacles (thesis figure 21 as data)."""
        boxes, radar_xy_m, stamp_ns = self.latest.snapshot()
        grid = obstacle_grid(boxes, radar_xy_m, self.config.fusion)
        return [(TOPIC_MAP, occupancy_grid_msg(grid, stamp_ns, self.config.fusion))]
