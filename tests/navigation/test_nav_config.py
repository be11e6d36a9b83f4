"""Configuration: thesis defaults, TOML loading, and loud failure on a misspelt field."""

from __future__ import annotations

import pydantic
import pytest

from navigation.config import CfarConfig, NavigationConfig, load_config


def test_defaults_are_the_thesis_values():
    config = NavigationConfig()
    assert (config.lidar.eps_m, config.lidar.min_samples, config.lidar.box_max_size_m) == (1, 10, 3)
    assert 2 * config.cfar.guard_cells_per_side == 10  # table 4.2, read as a total
    # table 4.2's 100 training cells do not fit a ring of 72 beams; 61 cells do beside them
    assert config.cfar.axis == "azimuth"
    assert 2 * (config.cfar.training_cells_per_side + config.cfar.guard_cells_per_side) + 1 <= 72
    assert (config.cfar.detector, config.cfar.false_alarm_rate) == ("soca", 0.1)
    camera = config.camera
    assert (camera.canny_threshold1, camera.canny_threshold2) == (170, 260)
    assert (camera.rho_px, camera.theta_deg, camera.threshold) == (1.1, 1.0, 190)


def test_toml_overrides_nested_values(tmp_path):
    path = tmp_path / "nav.toml"
    path.write_text(
        '[lidar]\nvoxel_size_m = 0.3\nmethod = "birch"\n[lidar.ground]\nwater_level_z_m = -2.0\n'
        '[cfar]\ndetector = "os"\nos_rank = 50\n'
    )
    config = load_config(path)
    assert config.lidar.voxel_size_m == 0.3 and config.lidar.method == "birch"
    assert config.lidar.ground.water_level_z_m == -2.0
    assert config.cfar.os_rank == 50 and config.camera.threshold == 190


def test_lidar_worker_defaults_to_a_process_and_names_only_known_kinds():
    assert NavigationConfig().lidar.worker == "process"
    assert NavigationConfig.model_validate({"lidar": {"worker": "thread"}}).lidar.worker == "thread"
    with pytest.raises(pydantic.ValidationError, match="worker"):
        NavigationConfig.model_validate({"lidar": {"worker": "fork"}})


def test_wrong_field_is_named(tmp_path):
    path = tmp_path / "nav.toml"
    path.write_text("[lidar]\nepsilon = 2.0\n")
    with pytest.raises(pydantic.ValidationError, match="epsilon"):
        load_config(path)


def test_invalid_values_are_refused():
    with pytest.raises(pydantic.ValidationError, match="os_rank"):
        CfarConfig(os_rank=61)
    with pytest.raises(pydantic.ValidationError):
        CfarConfig(false_alarm_rate=1.5)


def test_configs_are_frozen():
    with pytest.raises(pydantic.ValidationError):
        NavigationConfig().lidar.eps_m = 2.0  # type: ignore[misc]
