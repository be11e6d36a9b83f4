"""LIDAR obstacle extraction: scan -> obstacle points -> voxels -> clusters -> boxes.

The pure pipeline of thesis 3.5.3 (DBSCAN, then the bounding-box refinement), preceded by
the reductions that make DBSCAN affordable on a full 345,600-ray scan (lidar_filter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from navigation.boxes import Boxes, refine_boxes
from navigation.clustering import cluster_labels
from navigation.config import LidarConfig
from navigation.lidar_filter import obstacle_mask, range_mask, voxel_downsample

NOISE = -1  # DBSCAN noise, and every point removed before clustering


@dataclass(frozen=True)
class LidarResult:
    """Outcome of one scan.

    labels : (n,) int32, cluster of every input point; -1 for noise and removed points.
    obstacle : (n,) bool, points that survived the range crop and water/terrain removal.
    boxes : refined boxes of all clusters.
    num_clusters : clusters found.
    num_clustered_samples : points (or voxels) handed to the clustering.
    water_level_z_m : water height used, None when none was found.
    """

    labels: np.ndarray
    obstacle: np.ndarray
    boxes: Boxes
    num_clusters: int
    num_clustered_samples: int
    water_level_z_m: float | None


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
    """The whole LIDAR step. points : (n, >=3) float32, sensor frame, metres."""
    keep, water_z = obstacle_points(points, config)
    index = np.flatnonzero(keep)
    xyz = np.ascontiguousarray(points[index, :3])
    obstacle_labels, samples = cluster_obstacles(xyz, config)
    labels = np.full(points.shape[0], NOISE, dtype=np.int32)
    labels[index] = obstacle_labels
    boxes = refine_boxes(xyz, obstacle_labels, config.box_max_size_m, config.shrink_boxes)
    num_clusters = int(np.unique(obstacle_labels[obstacle_labels >= 0]).size)
    return LidarResult(labels, keep, boxes, num_clusters, samples, water_z)
