"""LIDAR: analytic ranges against a known wall, frames, filtering, noise and the message."""

from __future__ import annotations

import numpy as np
import pytest

from simulator.config import LidarConfig, MountConfig
from simulator.frames import Pose2D
from simulator.lidar import Lidar, lidar_directions
from simulator.materials import WATER, Material
from tests.simulator.sim_scenes import WALL, box_scene

WALL_DISTANCE_M = 20.0


@pytest.fixture(scope="module")
def lidar():
    sensor = Lidar(LidarConfig(mount=MountConfig(z_m=3.0)), threads=2)
    yield sensor
    sensor.close()


def test_default_grid_is_the_thesis_scan():
    directions = lidar_directions(LidarConfig())
    assert directions.shape == (345_600, 3)  # 1440 azimuths x 240 elevations (table 4.3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-6)
    elevation_deg = np.degrees(np.arcsin(directions[:, 2]))
    assert elevation_deg.min() == pytest.approx(-29.875, abs=1e-4)
    assert elevation_deg.max() == pytest.approx(29.875, abs=1e-4)


def test_ranges_to_a_wall_match_the_analytic_range_within_1cm(lidar):
    # Wall face at x = 20 m spanning y and z far beyond the 60 deg field of view at that range.
    scene = box_scene((WALL_DISTANCE_M, -200.0, -50.0), (22.0, 200.0, 50.0))
    points = lidar.scan(scene, Pose2D(0.0, 0.0, 0.0))
    assert len(points) > 1000
    directions = points[:, :3] / np.linalg.norm(points[:, :3], axis=1, keepdims=True)
    analytic_range = WALL_DISTANCE_M / directions[:, 0]
    np.testing.assert_allclose(np.linalg.norm(points[:, :3], axis=1), analytic_range, atol=0.01)
    np.testing.assert_allclose(points[:, 0], WALL_DISTANCE_M, atol=0.01)
    np.testing.assert_allclose(points[:, 3], WALL.lidar_reflectivity)


def test_points_are_in_the_sensor_frame(lidar):
    # The same wall north of the vessel, seen with the vessel facing north: ahead in x.
    scene = box_scene((-200.0, 30.0, -50.0), (200.0, 31.0, 50.0))
    points = lidar.scan(scene, Pose2D(5.0, 0.0, np.pi / 2))
    np.testing.assert_allclose(points[:, 0], 30.0, atol=0.01)
    # Sensor 3 m above the water line: the wall spans z down to the water plane at -3 m and more.
    assert points[:, 2].min() < -3.0 < points[:, 2].max()


def test_range_limit_and_no_return_surfaces():
    near = Lidar(LidarConfig(range_max_m=15.0), threads=1)
    try:
        wall = box_scene((WALL_DISTANCE_M, -200.0, -50.0), (22.0, 200.0, 50.0))
        assert len(near.scan(wall, Pose2D(0, 0, 0))) == 0  # beyond range
        mirror = Material("mirror", 0.0, 0.0, (0, 0, 0))
        flat = box_scene((-500.0, -500.0, -1.0), (500.0, 500.0, 0.0), mirror)
        assert len(near.scan(flat, Pose2D(0, 0, 0))) == 0  # reflectivity 0: no returns
    finally:
        near.close()


def test_water_gives_weak_returns_on_the_water_plane():
    """Unity's LIDAR hit the thesis's water collision mesh; navigation removes those points."""
    near = Lidar(LidarConfig(range_max_m=15.0), threads=1)
    try:
        water = box_scene((-500.0, -500.0, -1.0), (500.0, 500.0, 0.0), WATER)
        points = near.scan(water, Pose2D(0, 0, 0))
        assert len(points) > 0
        np.testing.assert_allclose(points[:, 3], WATER.lidar_reflectivity)
        assert np.all(points[:, 2] < 0.0)  # below the sensor, on the plane
    finally:
        near.close()


def test_range_noise_is_seeded_and_of_the_configured_size():
    scene = box_scene((WALL_DISTANCE_M, -200.0, -50.0), (22.0, 200.0, 50.0))
    cfg = LidarConfig(range_noise_std_m=0.05)
    scans = []
    for _ in range(2):
        sensor = Lidar(cfg, threads=1, seed=11)
        scans.append(sensor.scan(scene, Pose2D(0, 0, 0)))
        sensor.close()
    np.testing.assert_array_equal(scans[0], scans[1])
    measured_m = np.linalg.norm(scans[0][:, :3], axis=1)
    true_m = WALL_DISTANCE_M / (scans[0][:, 0] / measured_m)  # along the same ray direction
    assert np.std(measured_m - true_m) == pytest.approx(0.05, rel=0.1)
    assert abs(np.mean(measured_m - true_m)) < 0.01


def test_thread_count_does_not_change_the_scan(small_scene):
    one, two = Lidar(threads=1), Lidar(threads=2)
    try:
        pose = small_scene.start_pose
        np.testing.assert_array_equal(one.scan(small_scene, pose), two.scan(small_scene, pose))
    finally:
        one.close()
        two.close()


def test_scan_of_the_thesis_scene_sees_banks_and_no_water(small_scene, lidar):
    points = lidar.scan(small_scene, small_scene.start_pose)
    assert points.dtype == np.float32 and points.shape[1] == 4
    assert len(points) > 1000
    assert np.all(points[:, 3] > 0)
    assert np.linalg.norm(points[:, :3], axis=1).max() <= lidar.cfg.range_max_m + 1e-3


def test_pointcloud2_message(lidar, check_canonical):
    scene = box_scene((WALL_DISTANCE_M, -200.0, -50.0), (22.0, 200.0, 50.0))
    points = lidar.scan(scene, Pose2D(0, 0, 0))
    msg = lidar.message(points, stamp_ns=1_700_000_000_250_000_000)
    assert msg["header"] == {
        "stamp": {"sec": 1_700_000_000, "nanosec": 250_000_000},
        "frame_id": "lidar",
    }
    assert msg["point_step"] == 16
    assert msg["row_step"] == 16 * len(points) == len(msg["data"])
    assert (msg["height"], msg["width"]) == (1, len(points))
    assert [(f["name"], f["offset"], f["datatype"], f["count"]) for f in msg["fields"]] == [
        ("x", 0, 7, 1),
        ("y", 4, 7, 1),
        ("z", 8, 7, 1),
        ("intensity", 12, 7, 1),
    ]
    assert isinstance(msg["data"], bytes)
    np.testing.assert_array_equal(np.frombuffer(msg["data"], "<f4").reshape(-1, 4), points)
    check_canonical("sensor_msgs/msg/PointCloud2", msg)
