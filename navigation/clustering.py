"""Clustering of obstacle points: DBSCAN (thesis 2.4.4), K-means (2.4.2), BIRCH (2.4.3).

All functions take xyz : (n, 3) float and optional per-point weights (points per voxel) and
return labels : (n,) int32 with -1 for noise (only DBSCAN produces noise).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import sparse
from sklearn.cluster import DBSCAN, Birch, KMeans
from sklearn.neighbors import NearestNeighbors

from navigation.config import LidarConfig


def adaptive_eps(xyz: np.ndarray, config: LidarConfig) -> np.ndarray:
    """Per-point eps of thesis eq. 2.4.9: eps_i = n * theta * pi * d_i / 180, floored.

    The arc length between neighbouring rays grows with range d_i, so a fixed eps splits far
    objects; n is ``eps_precision_factor``, theta the angular resolution in degrees.
    xyz : (n, 3) float, sensor frame -> (n,) float64 metres.
    """
    distance_m: npt.NDArray[np.float64] = np.linalg.norm(np.asarray(xyz, np.float64), axis=1)
    arc_m = config.angular_resolution_deg * np.pi * distance_m / 180.0
    return np.maximum(config.eps_precision_factor * arc_m, config.eps_min_m)


def dbscan_labels(
    xyz: np.ndarray, config: LidarConfig, weights: np.ndarray | None = None
) -> np.ndarray:
    """DBSCAN with the fixed eps of table 4.4, or the adaptive eps of eq. 2.4.9.

    With adaptive eps two points are neighbours when their distance is within the smaller of
    their two radii (a symmetric relation, as DBSCAN requires); the pairs come from one radius
    query at the largest radius and feed DBSCAN as a precomputed sparse graph.
    """
    if xyz.shape[0] == 0:
        return np.empty(0, dtype=np.int32)
    if not config.adaptive_eps:
        model = DBSCAN(eps=config.eps_m, min_samples=config.min_samples, n_jobs=config.n_jobs)
        return np.asarray(model.fit_predict(xyz, sample_weight=weights), dtype=np.int32)
    eps_m = adaptive_eps(xyz, config)
    search = NearestNeighbors(radius=float(eps_m.max()), n_jobs=config.n_jobs).fit(xyz)
    graph = search.radius_neighbors_graph(xyz, mode="distance", sort_results=False).tocoo()
    pair_eps = np.minimum(eps_m[graph.row], eps_m[graph.col])
    keep = graph.data <= pair_eps
    # Distances scaled by the pair's radius so that one global eps of 1 applies; the tiny
    # offset keeps zero distances (duplicate points) as stored entries of the sparse graph.
    scaled = graph.data[keep] / pair_eps[keep] + 1e-9
    n = xyz.shape[0]
    normalised = sparse.csr_matrix((scaled, (graph.row[keep], graph.col[keep])), shape=(n, n))
    model = DBSCAN(eps=1.0 + 1e-6, min_samples=config.min_samples, metric="precomputed")
    return np.asarray(model.fit_predict(normalised, sample_weight=weights), dtype=np.int32)


def kmeans_labels(
    xyz: np.ndarray, config: LidarConfig, weights: np.ndarray | None = None
) -> np.ndarray:
    """K-means with ``n_clusters`` centres (thesis 2.4.2); every point gets a cluster."""
    k = min(config.n_clusters, xyz.shape[0])
    if k == 0:
        return np.empty(0, dtype=np.int32)
    model = KMeans(n_clusters=k, n_init=1, random_state=0)
    return np.asarray(model.fit_predict(xyz, sample_weight=weights), dtype=np.int32)


def birch_labels(
    xyz: np.ndarray, config: LidarConfig, weights: np.ndarray | None = None
) -> np.ndarray:
    """BIRCH sub-clusters of radius ``birch_threshold_m`` (thesis 2.4.3), merged by DBSCAN's
    eps: the CF-tree leaves are the micro-clusters, and leaves closer than eps join."""
    if xyz.shape[0] == 0:
        return np.empty(0, dtype=np.int32)
    del weights  # Birch has no sample weights; voxel counts only thin the input
    model = Birch(threshold=config.birch_threshold_m, n_clusters=None)
    leaf = model.fit_predict(xyz)
    centres = model.subcluster_centers_
    merge = DBSCAN(eps=config.eps_m, min_samples=1).fit_predict(centres)
    return np.asarray(merge[leaf], dtype=np.int32)


CLUSTERERS = {"dbscan": dbscan_labels, "kmeans": kmeans_labels, "birch": birch_labels}


def cluster_labels(
    xyz: np.ndarray, config: LidarConfig, weights: np.ndarray | None = None
) -> np.ndarray:
    """Labels from the method named in ``config.method``: (n, 3) float -> (n,) int32."""
    return CLUSTERERS[config.method](xyz, config, weights)
