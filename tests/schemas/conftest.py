"""Shared fixtures for the schemas tests."""

from __future__ import annotations

import numpy as np
import pytest

from schemas.pointcloud import pack_points

#: LIDAR scan size of the thesis set-up: 1440 azimuths x 240 elevations, x,y,z,intensity f32.
LIDAR_POINTS = 345_600
POINT_STEP_BYTES = 16


def make_pointcloud(num_points: int = LIDAR_POINTS, seed: int = 0) -> dict:
    """A canonical-ready PointCloud2 dict: (num_points, 4) float32 x, y, z, intensity."""
    points = np.random.default_rng(seed).random((num_points, 4), dtype=np.float32)
    return pack_points(points, 1_700_000_000_000_000_005, "lidar")


@pytest.fixture
def pointcloud() -> dict:
    return make_pointcloud()
