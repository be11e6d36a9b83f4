"""Point-cloud reduction ahead of clustering: range crop, water/terrain removal, voxels.

DBSCAN's cost follows the number of neighbours within eps, and the dense water and terrain
returns near the sensor dominate it (performance-measurements §2(e)); these steps remove them
and thin what is left, all vectorised over the points.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from navigation.config import GroundConfig


def range_mask(points: np.ndarray, range_min_m: float, range_max_m: float) -> np.ndarray:
    """Points with finite xyz and a horizontal range in [range_min_m, range_max_m].

    points : (n, >=3) float -> (n,) bool.
    """
    x = points[:, 0]
    y = points[:, 1]
    range_sq: npt.NDArray[np.float64] = x * x + y * y
    finite: npt.NDArray[np.bool_] = np.isfinite(range_sq) & np.isfinite(points[:, 2])
    return finite & (range_sq >= range_min_m**2) & (range_sq <= range_max_m**2)


def estimate_water_level(z_m: np.ndarray, bin_m: float) -> float | None:
    """Height of the most populated bin below the sensor, or None without such points.

    The water plane is flat and wide, so it fills one height bin far more than terrain or
    objects do. z_m : (n,) float, heights in the sensor frame (sensor at z = 0).
    """
    below = z_m[z_m < 0.0]
    if below.size == 0:
        return None
    low = float(below.min())
    n_bins = max(1, int(np.ceil((0.0 - low) / bin_m)))
    counts, edges = np.histogram(below, bins=n_bins, range=(low, low + n_bins * bin_m))
    best = int(np.argmax(counts))
    return float(np.median(below[(below >= edges[best]) & (below <= edges[best + 1])]))


def local_ground_height(points: np.ndarray, extent_m: float, config: GroundConfig) -> np.ndarray:
    """Robust terrain height under each point: (n, >=3) float -> (n,) float32 metres.

    Per grid cell the second-lowest return (one stray low return, e.g. multipath, must not
    sink the ground of a whole neighbourhood), then a grey-scale opening (erode, dilate) of width
    ``opening_width_m``: objects narrower than that vanish from the estimate while linear
    slopes pass through unchanged. Empty cells are ignored by both passes.
    """
    cell = config.cell_size_m
    # Padding by the opening width keeps the edge cells' upslope windows inside the grid.
    half_m = extent_m + config.opening_width_m
    n_cells = int(np.ceil(2.0 * half_m / cell)) + 1
    ix = np.clip(((points[:, 0] + half_m) / cell).astype(np.intp), 0, n_cells - 1)
    iy = np.clip(((points[:, 1] + half_m) / cell).astype(np.intp), 0, n_cells - 1)
    flat: npt.NDArray[np.intp] = iy * n_cells + ix
    grid = _second_lowest_per_cell(flat, points[:, 2], n_cells * n_cells)
    grid = grid.reshape(n_cells, n_cells)
    width = max(1, round(config.opening_width_m / cell) | 1)
    kernel = np.ones((width, width), dtype=np.uint8)
    eroded = cv2.erode(grid, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=np.inf)
    eroded[np.isinf(eroded)] = -np.inf  # empty neighbourhoods must not win the dilation
    opened = cv2.dilate(eroded, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=-np.inf)
    return opened.reshape(-1)[flat]


def _second_lowest_per_cell(flat: np.ndarray, z_m: np.ndarray, n_cells: int) -> np.ndarray:
    """Second-lowest height per cell, the lowest where a cell holds a single value.

    flat : (n,) intp cell index, z_m : (n,) float -> (n_cells,) float32, +inf when empty.
    """
    z = z_m.astype(np.float32, copy=False)
    lowest = np.full(n_cells, np.inf, dtype=np.float32)
    np.minimum.at(lowest, flat, z)
    above = z > lowest[flat]
    second = np.full(n_cells, np.inf, dtype=np.float32)
    np.minimum.at(second, flat[above], z[above])
    return np.where(np.isinf(second), lowest, second)


def obstacle_mask(
    points: np.ndarray, extent_m: float, config: GroundConfig
) -> tuple[np.ndarray, float | None]:
    """Points standing clear of the water and of the local terrain.

    points : (n, >=3) float, already range-cropped to ``extent_m``.
    Returns keep : (n,) bool and the water level used (None if none was found).
    """
    z = points[:, 2]
    water_z = config.water_level_z_m
    if water_z is None:
        water_z = estimate_water_level(z, config.height_bin_m)
    keep = np.ones(z.shape, dtype=bool)
    if water_z is not None:
        keep &= z > water_z + config.water_margin_m
    if points.shape[0]:
        ground_z = local_ground_height(points, extent_m, config)
        keep &= z > ground_z + config.ground_margin_m
    return keep, water_z


@dataclass(frozen=True)
class Voxels:
    """A voxel-downsampled cloud.

    centroids : (v, 3) float32, mean position of the points in each occupied voxel.
    counts : (v,) int64, points per voxel (DBSCAN sample weights).
    inverse : (n,) intp, voxel index of every input point (maps voxel labels back).
    """

    centroids: np.ndarray
    counts: np.ndarray
    inverse: np.ndarray


def voxel_downsample(xyz: np.ndarray, voxel_size_m: float) -> Voxels:
    """Group points into cubic voxels of ``voxel_size_m``: xyz (n, 3) float -> Voxels."""
    if voxel_size_m <= 0.0 or xyz.shape[0] == 0:
        n = xyz.shape[0]
        return Voxels(
            np.asarray(xyz, np.float32), np.ones(n, np.int64), np.arange(n, dtype=np.intp)
        )
    keys = np.floor(xyz / voxel_size_m).astype(np.int64)
    keys -= keys.min(axis=0)
    span = keys.max(axis=0) + 1
    packed = (keys[:, 0] * span[1] + keys[:, 1]) * span[2] + keys[:, 2]
    _, inverse, counts = np.unique(packed, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    centroids = np.empty((counts.size, 3), dtype=np.float32)
    for axis in range(3):  # three bincounts beat one np.add.at on (n, 3)
        centroids[:, axis] = np.bincount(inverse, weights=xyz[:, axis]) / counts
    return Voxels(centroids, counts.astype(np.int64), inverse.astype(np.intp))
