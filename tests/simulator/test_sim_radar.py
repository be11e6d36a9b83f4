"""RADAR: a known reflector lands in its (beam, range cell); clutter; the RadarImage message."""

from __future__ import annotations

import numpy as np
import pytest

from simulator.config import MountConfig, RadarConfig
from simulator.frames import Pose2D
from simulator.props import MeshPart
from simulator.radar import Radar, RadarGeometry
from simulator.scene import Scene
from tests.simulator.sim_scenes import WALL, box_part

CFG = RadarConfig(mount=MountConfig(z_m=3.0))


def reflector_scene(range_m: float, azimuth_deg: float, vessel: Pose2D) -> Scene:
    """A 40 m tall post whose near face is `range_m` from the radar at `azimuth_deg` (relative
    to the vessel heading), +-2 deg wide: both rays of the beam (+-1.25 deg) hit it, the
    neighbouring beams (from +-2.5 deg) do not, and all 30 elevation rays reach it."""
    bearing = vessel.yaw_rad + np.radians(azimuth_deg)
    centre = np.array([vessel.x_m, vessel.y_m]) + (range_m + 0.5) * np.array(
        [np.cos(bearing), np.sin(bearing)]
    )
    half_width_m = range_m * np.tan(np.radians(2.0))
    part = box_part((-0.5, -half_width_m, -20.0), (0.5, half_width_m, 20.0))
    c, s = np.cos(bearing), np.sin(bearing)
    rotated = part.vertices @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    moved = rotated + np.array([centre[0], centre[1], 0.0])
    return Scene([MeshPart(moved, part.faces, part.material)], water_level_m=0.0)


def test_geometry_follows_table_4_1_with_4_rays_across_a_beam():
    """Table 4.1's beams and cells; 4 rays across a beam where the table has 2 (config.py)."""
    geometry = RadarGeometry(RadarConfig())
    assert geometry.num_beams == 72  # 360 / 5 deg
    assert geometry.num_cells == 25  # 100 m / 4 m
    assert geometry.directions_sensor.shape == (72 * 30 * 4, 3)
    elevation_deg = np.degrees(np.arcsin(geometry.directions_sensor[:, 2]))
    assert elevation_deg.min() == pytest.approx(-7.25, abs=1e-4)  # 15 deg in 30 rays
    assert np.all(np.bincount(geometry.beam_index) == 120)
    azimuth_deg = np.degrees(np.arctan2(*geometry.directions_sensor[:4, 1::-1].T))
    np.testing.assert_allclose(azimuth_deg, [-1.875, -0.625, 0.625, 1.875], atol=1e-4)


@pytest.mark.parametrize(
    ("range_m", "azimuth_deg", "yaw_rad"),
    [(50.0, 30.0, 0.0), (21.0, 200.0, 1.0), (90.0, 355.0, -2.5)],
)
def test_known_reflector_lands_in_its_cell(range_m, azimuth_deg, yaw_rad):
    vessel = Pose2D(12.0, -7.0, yaw_rad)
    radar = Radar(CFG)
    try:
        image = radar.sweep(reflector_scene(range_m, azimuth_deg, vessel), vessel)
    finally:
        radar.close()
    beam = round(azimuth_deg / 5.0) % 72
    cell = int(range_m // 4.0)
    assert image.shape == (72, 25) and image.dtype == np.float32
    # eq. 3.5.3: all 30 x 4 rays of the beam hit, each contributing the reflector's ref_i.
    assert image[beam, cell] == pytest.approx(120 * WALL.radar_reflectance)
    image[beam, cell] = 0.0
    assert not image.any()


def test_rayleigh_clutter_is_seeded_and_scaled():
    empty = Scene([box_part((1000, 1000, 0), (1001, 1001, 1))], water_level_m=0.0)
    cfg = RadarConfig(clutter_scale=0.5)
    images = []
    for _ in range(2):
        radar = Radar(cfg, seed=4)
        images.append(radar.sweep(empty, Pose2D(0, 0, 0)))
        radar.close()
    np.testing.assert_array_equal(images[0], images[1])
    assert np.all(images[0] > 0)
    assert images[0].mean() == pytest.approx(0.5 * np.sqrt(np.pi / 2), rel=0.1)


def test_radar_sees_the_moored_vessels_of_the_thesis_scene(small_scene):
    radar = Radar(RadarConfig(range_max_m=2000.0, range_step_m=10.0))
    try:
        image = radar.sweep(small_scene, small_scene.start_pose)
    finally:
        radar.close()
    assert image.sum() > 0
    assert image.max() >= 100.0  # at least one vessel ray (reflectance 100, thesis 4.1)


def test_radar_image_message(check_canonical):
    radar = Radar(CFG)
    try:
        image = radar.sweep(reflector_scene(50.0, 30.0, Pose2D(0, 0, 0)), Pose2D(0, 0, 0))
        msg = radar.message(image, stamp_ns=3_000_000_123)
    finally:
        radar.close()
    assert msg["header"] == {"stamp": {"sec": 3, "nanosec": 123}, "frame_id": "radar"}
    assert (msg["num_beams"], msg["num_cells"]) == (72, 25)
    assert msg["reflectance"].dtype == np.float32 and msg["reflectance"].shape == (72 * 25,)
    assert msg["reflectance"].reshape(72, 25)[6, 12] == image[6, 12] > 0
    assert msg["azimuth_step_rad"] == pytest.approx(np.radians(5.0))
    assert msg["beam_width_elevation_rad"] == pytest.approx(np.radians(15.0))
    check_canonical("riverbridge_msgs/msg/RadarImage", msg)
