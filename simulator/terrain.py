"""Terrain height fields: the procedural thesis valley, real elevation data, and their meshes.

A `HeightField` is a regular grid in the map frame (x east, y north, z up, metres). Row index
grows northwards and column index eastwards, so `heights_m[i, j]` sits at
`(origin_x_m + j * spacing_m, origin_y_m + i * spacing_m)`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np


@dataclass(frozen=True)
class HeightField:
    """heights_m : (rows, cols) float32, metres; spacing_m between neighbouring samples."""

    heights_m: np.ndarray
    spacing_m: float
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0

    @property
    def extent_m(self) -> tuple[float, float]:
        """(width east, height north) covered by the samples, metres."""
        rows, cols = self.heights_m.shape
        return ((cols - 1) * self.spacing_m, (rows - 1) * self.spacing_m)

    def centred(self) -> HeightField:
        """The same grid moved so that its centre is the map origin."""
        width_m, height_m = self.extent_m
        return HeightField(self.heights_m, self.spacing_m, -width_m / 2, -height_m / 2)

    def resampled(self, cells: int) -> HeightField:
        """Resample to `cells` x `cells` cells over the same square-ish extent (area-averaged)."""
        width_m, height_m = self.extent_m
        spacing_m = max(width_m, height_m) / cells
        cols = round(width_m / spacing_m) + 1
        rows = round(height_m / spacing_m) + 1
        interpolation = cv2.INTER_AREA if cols < self.heights_m.shape[1] else cv2.INTER_LINEAR
        heights = cv2.resize(self.heights_m, (cols, rows), interpolation=interpolation)
        return HeightField(heights.astype(np.float32), spacing_m, self.origin_x_m, self.origin_y_m)

    def height_at(self, x_m: np.ndarray, y_m: np.ndarray) -> np.ndarray:
        """Bilinear height at map points; points outside the grid take the nearest edge value."""
        rows, cols = self.heights_m.shape
        fx = np.clip((np.asarray(x_m) - self.origin_x_m) / self.spacing_m, 0, cols - 1.000001)
        fy = np.clip((np.asarray(y_m) - self.origin_y_m) / self.spacing_m, 0, rows - 1.000001)
        j, i = fx.astype(np.int64), fy.astype(np.int64)
        tx, ty = fx - j, fy - i
        h = self.heights_m
        south = h[i, j] * (1 - tx) + h[i, j + 1] * tx
        north = h[i + 1, j] * (1 - tx) + h[i + 1, j + 1] * tx
        return south * (1 - ty) + north * ty


def heightfield_mesh(field: HeightField) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate the grid: vertices (rows*cols, 3) float64, faces (2*(rows-1)*(cols-1), 3) int64.

    Faces wind counter-clockwise seen from above, so their normals point up.
    """
    rows, cols = field.heights_m.shape
    xs = field.origin_x_m + np.arange(cols) * field.spacing_m
    ys = field.origin_y_m + np.arange(rows) * field.spacing_m
    gx, gy = np.meshgrid(xs, ys)
    vertices = np.column_stack([gx.ravel(), gy.ravel(), field.heights_m.ravel()])
    corner = (np.arange(rows - 1)[:, None] * cols + np.arange(cols - 1)[None, :]).ravel()
    sw, se, nw, ne = corner, corner + 1, corner + cols, corner + cols + 1
    faces = np.concatenate([np.column_stack([sw, se, ne]), np.column_stack([sw, ne, nw])])
    return vertices, faces


# --- real elevation data ---------------------------------------------------------------------


def load_xyz(path: str | Path) -> HeightField:
    """Read an ASCII `.xyz` grid (`x y z` per line, as the state open-data portals publish).

    The points must lie on a regular grid (any order); missing samples take the lowest height.
    Coordinates stay absolute (e.g. UTM); use `HeightField.centred` for a local map frame.
    """
    points = np.loadtxt(path, dtype=np.float64, usecols=(0, 1, 2), ndmin=2)
    xs, ys = np.unique(points[:, 0]), np.unique(points[:, 1])
    spacing_m = float(np.median(np.diff(xs))) if xs.size > 1 else float(np.median(np.diff(ys)))
    cols = round((xs[-1] - xs[0]) / spacing_m) + 1
    rows = round((ys[-1] - ys[0]) / spacing_m) + 1
    heights = np.full((rows, cols), np.nan, dtype=np.float32)
    j = np.rint((points[:, 0] - xs[0]) / spacing_m).astype(np.int64)
    i = np.rint((points[:, 1] - ys[0]) / spacing_m).astype(np.int64)
    heights[i, j] = points[:, 2]
    heights[np.isnan(heights)] = np.nanmin(heights)
    return HeightField(heights, spacing_m, float(xs[0]), float(ys[0]))


def save_xyz(field: HeightField, path: str | Path) -> None:
    """Write the grid as `x y z` lines, row by row from the south-west corner."""
    vertices, _ = heightfield_mesh(field)
    np.savetxt(path, vertices, fmt="%.3f")


def load_heightmap(
    path: str | Path, spacing_m: float, height_range_m: tuple[float, float]
) -> HeightField:
    """Read an 8- or 16-bit greyscale heightmap image (row 0 = north, as images are drawn).

    Grey 0 maps to `height_range_m[0]`, the dtype's full scale to `height_range_m[1]`.
    """
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED | cv2.IMREAD_ANYDEPTH)
    if image is None:
        raise ValueError(f"cannot read heightmap image {path}")
    if image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    full_scales = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}
    if image.dtype not in full_scales:
        raise ValueError(f"heightmap {path} must be 8- or 16-bit, got {image.dtype}")
    full_scale = full_scales[image.dtype]
    low_m, high_m = height_range_m
    heights = low_m + image[::-1].astype(np.float32) / full_scale * (high_m - low_m)
    return HeightField(np.ascontiguousarray(heights, dtype=np.float32), spacing_m)


def load_terrain(
    path: str | Path, spacing_m: float, height_range_m: tuple[float, float]
) -> HeightField:
    """Dispatch on the suffix: `.xyz`/`.txt` as an elevation grid, anything else as an image."""
    if Path(path).suffix.lower() in {".xyz", ".txt"}:
        return load_xyz(path)
    return load_heightmap(path, spacing_m, height_range_m)
