"""LIDAR obstacle extraction: scan -> obstacle points -> voxels -> clusters -> boxes.

The pure pipeline of thesis 3.5.3 (DBSCAN, then the bounding-box refinement), preceded by
the reductions that make DBSCAN affordable on a full 345,600-ray scan (lidar_filter).
`process_scan` is the one pipeline: the node runs it through a `LidarWorker`
(navigation.lidar_worker), tests and benchmarks call it directly.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from navigation.boxes import Boxes, refine_boxes
from navigation.clustering import cluster_labels
from navigation.config import LidarConfig
from navigation.lidar_filter import obstacle_mask, range_mask, voxel_downsample

NOISE = -1  # DBSCAN noise, and every point removed before clustering


# Sub-step name -> (start_ns, end_ns) wall clock, for stage tracing (docs/tracing.md)
StepTimes = dict[str, tuple[int, int]]


@dataclass(frozen=True)
class LidarResult:
    """Outcome of one scan: small enough to come back from a worker process (no per-point
    arrays; `labels` and `obstacle` expand the obstacle points' labels on demand).

    boxes : refined boxes of all clusters, sensor frame.
    num_clusters : clusters found.
    obstacle_index : (k,) int64, the input points that survived the range crop and the
        water/terrain removal; obstacle_labels : (k,) int32, their clusters (-1 noise).
    num_points : n, the input points.
    num_clustered_samples : points (or voxels) handed to the clustering.
    water_level_z_m : water height used, None when none was found.
    steps : wall-clock spans of ``filter``, ``dbscan`` and ``boxes`` (the thesis's 29 ms and
        186 ms, table A.1), traced as ``process.<step>``.
    """

    boxes: Boxes
    num_clusters: int
    obstacle_index: np.ndarray
    obstacle_labels: np.ndarray
    num_points: int
    num_clustered_samples: int
    water_level_z_m: float | None
    steps: StepTimes

    @property
    def labels(self) -> np.ndarray:
        """(n,) int32, the cluster of every input point; -1 for noise and removed points."""
        labels = np.full(self.num_points, NOISE, dtype=np.int32)
        labels[self.obstacle_index] = self.obstacle_labels
        return labels

    @property
    def obstacle(self) -> np.ndarray:
        """(n,) bool, the points that survived the crop and the water/terrain removal."""
        keep = np.zeros(self.num_points, dtype=bool)
        keep[self.obstacle_index] = True
        return keep


def obstacle_points(points: np.ndarray, config: LidarConfig) -> tuple[np.ndarray, float | None]:
    """Range crop plus water/terrain removal: points (n, >=3) -> keep (n,) bool, water z."""
    in_range = range_mask(points, config.range_min_m, config.range_max_m)
    index = np.flatnonzero(in_range)
    keep_in_range, water_z = obstacle_mask(points[index, :3], config.range_max_m, config.ground)
    keep = np.zeros(points.shape[0], dtype=bool)
    keep[index[keep_in_range]] = True
    return keep, water_z


def cluster_obstacles(xyz: np.ndarray, config: LidarConfig) -> tuple[np.ndarray, int]:
    """Voxel-downsample, cluster the voxels, map labels back: (k, 3) -> (k,) int32, samples.

    Voxel centroids carry their point counts as DBSCAN sample weights, so ``min_samples``
    still counts LIDAR returns rather than voxels.
    """
    voxels = voxel_downsample(xyz, config.voxel_size_m)
    voxel_labels = cluster_labels(voxels.centroids, config, weights=voxels.counts)
    return voxel_labels[voxels.inverse], int(voxels.centroids.shape[0])


def process_scan(points: np.ndarray, config: LidarConfig) -> LidarResult:
    """The whole LIDAR step, each sub-step timed: crop and water/terrain removal, voxels and
    clustering, boxes. points : (n, >=3) float32, sensor frame, metres, any strides."""
    t0 = time.time_ns()
    keep, water_z = obstacle_points(points, config)
    index = np.flatnonzero(keep)
    xyz = np.ascontiguousarray(points[index, :3])
    t1 = time.time_ns()
    labels, samples = cluster_obstacles(xyz, config)
    t2 = time.time_ns()
    boxes = refine_boxes(xyz, labels, config.box_max_size_m, config.shrink_boxes)
    t3 = time.time_ns()
    num_clusters = int(np.unique(labels[labels >= 0]).size)
    return LidarResult(
        boxes,
        num_clusters,
        index,
        labels,
        int(points.shape[0]),
        samples,
        water_z,
        {"filter": (t0, t1), "dbscan": (t1, t2), "boxes": (t2, t3)},
    )
