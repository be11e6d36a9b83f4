"""Radar image -> CFAR detections -> Cartesian -> RadarDetectionArray."""

from __future__ import annotations

import numpy as np
import pytest
from nav_scenes import radar_noise_image

from navigation.cfar import CfarDetector
from navigation.config import CfarConfig
from navigation.messages import header_msg
from navigation.radar import PolarGeometry, detect, detection_array_msg, radar_power


def radar_image_msg(power: np.ndarray) -> dict:
    beams, cells = power.shape
    return {
        "header": header_msg(3_000_000_000, "radar"),
        "azimuth_min_rad": 0.0,
        "azimuth_step_rad": float(np.float32(2 * np.pi / beams)),
        "beam_width_azimuth_rad": float(np.float32(np.deg2rad(5.0))),
        "beam_width_elevation_rad": float(np.float32(np.deg2rad(15.0))),
        "range_min_m": 0.0,
        "range_step_m": 0.25,
        "num_beams": beams,
        "num_cells": cells,
        "reflectance": power.reshape(-1),
    }


def test_targets_come_out_at_their_cartesian_position(check_canonical):
    power = radar_noise_image(72, 800, 1.0, seed=4)
    power[18, 400] = 200.0  # beam 18 = 90 deg, cell 400 = 100.125 m
    power[36, 80] = 200.0  # beam 36 = 180 deg, cell 80 = 20.125 m
    msg = radar_image_msg(power)
    check_canonical("riverbridge_msgs/msg/RadarImage", msg)
    image = radar_power(msg)
    assert np.shares_memory(image, msg["reflectance"])
    detector = CfarDetector.from_config(CfarConfig(false_alarm_rate=1e-4))
    found = detect(image, PolarGeometry.of(msg), detector)
    xy = np.column_stack([found.x_m, found.y_m])
    for expected in ([0.0, 100.125], [-20.125, 0.0]):
        assert np.min(np.linalg.norm(xy - expected, axis=1)) < 1e-3
    assert np.all(found.power > found.threshold)
    out = detection_array_msg(found, 3_000_000_000, "radar", detector)
    check_canonical("riverbridge_msgs/msg/RadarDetectionArray", out)
    assert out["detector"] == "soca" and len(out["detections"]) == len(found)


def test_wrong_reflectance_size_is_refused():
    msg = radar_image_msg(np.zeros((4, 10), np.float32))
    msg["num_cells"] = 11
    with pytest.raises(ValueError, match="reflectance"):
        radar_power(msg)
