"""Configuration (defaults, TOML, strictness) and the pose/ground-truth messages."""

from __future__ import annotations

import numpy as np
import pydantic
import pytest

from simulator.config import LidarConfig, SimConfig, load_config
from simulator.frames import Pose2D, quaternion_from_matrix, rotation_y, rotation_z
from simulator.messages import odometry, stamp, vessel_tf


def test_defaults_are_the_thesis_tables_but_the_radar_rays():
    """Table 4.1's 2 rays per beam miss a buoy at 67 m; ours are 4 (docs/quality.md)."""
    cfg = SimConfig()
    assert (cfg.lidar.horizontal_resolution_deg, cfg.lidar.vertical_fov_deg) == (0.25, 60.0)
    assert (cfg.radar.beam_width_azimuth_deg, cfg.radar.beam_width_elevation_deg) == (5.0, 15.0)
    assert (cfg.radar.rays_vertical, cfg.radar.rays_horizontal) == (30, 4)
    assert (cfg.camera.width_px, cfg.camera.height_px) == (640, 480)
    assert cfg.imu.rate_hz == cfg.vessel.physics_rate_hz == 50.0
    assert (cfg.scene.landing_stages, cfg.scene.moored_vessels) == (5, 2)


def test_toml_overrides_and_keeps_defaults(tmp_path):
    path = tmp_path / "sim.toml"
    path.write_text(
        "seed = 3\n[lidar]\nrange_max_m = 120.0\n[lidar.mount]\nz_m = 4.0\n"
        "[vessel]\ncurrent_velocity_mps = [0.4, 0.0]\n"
    )
    cfg = load_config(path)
    assert cfg.seed == 3
    assert cfg.lidar.range_max_m == 120.0 and cfg.lidar.mount.z_m == 4.0
    assert cfg.lidar.horizontal_resolution_deg == 0.25
    assert cfg.vessel.current_velocity_mps == (0.4, 0.0)


@pytest.mark.parametrize(
    ("toml", "field"),
    [
        ("[lidar]\nrange_maximum = 120.0\n", "range_maximum"),
        ('[camera]\nwidth_px = "wide"\n', "width_px"),
    ],
    ids=["unknown field", "wrong type"],
)
def test_a_bad_field_is_named(tmp_path, toml, field):
    path = tmp_path / "sim.toml"
    path.write_text(toml)
    with pytest.raises(pydantic.ValidationError, match=field):
        load_config(path)


def test_configs_are_frozen():
    with pytest.raises(pydantic.ValidationError):
        LidarConfig().range_max_m = 3.0  # type: ignore[misc]


def test_stamp_splits_nanoseconds():
    assert stamp(1_700_000_000_999_999_999) == {"sec": 1_700_000_000, "nanosec": 999_999_999}


def test_vessel_tf(check_canonical):
    msg = vessel_tf(Pose2D(10.0, -4.0, np.pi / 2), water_level_m=0.5, stamp_ns=5)
    (transform,) = msg["transforms"]
    assert transform["header"]["frame_id"] == "map" and transform["child_frame_id"] == "base_link"
    assert transform["transform"]["translation"] == {"x": 10.0, "y": -4.0, "z": 0.5}
    rotation = transform["transform"]["rotation"]
    assert (rotation["z"], rotation["w"]) == pytest.approx((np.sqrt(0.5), np.sqrt(0.5)))
    check_canonical("tf2_msgs/msg/TFMessage", msg)


def test_odometry(check_canonical):
    msg = odometry(Pose2D(1.0, 2.0, 0.0), 0.0, (3.0, -0.5), 0.1, stamp_ns=9)
    assert msg["child_frame_id"] == "base_link"
    assert msg["twist"]["twist"]["linear"] == {"x": 3.0, "y": -0.5, "z": 0.0}
    assert msg["twist"]["twist"]["angular"]["z"] == 0.1
    assert len(msg["pose"]["covariance"]) == 36
    check_canonical("nav_msgs/msg/Odometry", msg)


@pytest.mark.parametrize(("yaw", "pitch"), [(0.0, 0.0), (2.0, 0.3), (-3.0, -1.2), (np.pi, 0.0)])
def test_quaternion_from_matrix(yaw, pitch):
    x, y, z, w = quaternion_from_matrix(rotation_z(yaw) @ rotation_y(pitch))
    # Rebuild the matrix from the quaternion and compare.
    rebuilt = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(rebuilt, rotation_z(yaw) @ rotation_y(pitch), atol=1e-12)
