"""Radar image -> CFAR detections -> targets -> Cartesian -> RadarDetectionArray."""

from __future__ import annotations

import numpy as np
import pytest

from navigation.cfar import CfarDetector
from navigation.config import CfarConfig
from navigation.radar import (
    PolarGeometry,
    detect,
    detection_array_msg,
    radar_power,
    target_labels,
)
from tests.navigation.nav_scenes import radar_image_of, radar_noise_image


def radar_image_msg(power: np.ndarray) -> dict:
    return radar_image_of(power, 3_000_000_000, 0.25)


def test_targets_come_out_at_their_cartesian_position(check_canonical):
    power = radar_noise_image(72, 800, 1.0, seed=4)
    power[18, 400] = 200.0  # beam 18 = 90 deg, cell 400 = 100.125 m
    power[36, 80] = 200.0  # beam 36 = 180 deg, cell 80 = 20.125 m
    msg = radar_image_msg(power)
    check_canonical("riverbridge_msgs/msg/RadarImage", msg)
    image = radar_power(msg)
    assert np.shares_memory(image, msg["reflectance"])
    detector = CfarDetector.from_config(CfarConfig(false_alarm_rate=1e-4))
    found, targets = detect(image, PolarGeometry.of(msg), detector)
    for xy in (
        np.column_stack([found.x_m, found.y_m]),
        np.column_stack([targets.x_m, targets.y_m]),
    ):
        for expected in ([0.0, 100.125], [-20.125, 0.0]):
            assert np.min(np.linalg.norm(xy - expected, axis=1)) < 1e-3
    assert np.all(found.power > found.threshold)
    out = detection_array_msg(found, targets, 3_000_000_000, "radar", detector)
    check_canonical("riverbridge_msgs/msg/RadarDetectionArray", out)
    assert out["detector"] == "soca" and out["axis"] == "azimuth"
    assert len(out["detections"]) == len(found) and len(out["targets"]) == len(targets)
    by_cell = {(d["beam"], d["cell"]): d for d in out["detections"]}
    assert by_cell[(18, 400)]["power"] == 200.0
    target = out["targets"][by_cell[(18, 400)]["target"]]
    assert (target["peak_beam"], target["peak_cell"], target["num_cells"]) == (18, 400, 1)


def test_adjacent_cells_form_one_target_across_the_ring_seam():
    hits = np.zeros((72, 25), bool)
    hits[[71, 0, 1], 10] = True  # one target over the seam between beams 71 and 0
    hits[0, 11] = True  # diagonal neighbours join it
    hits[[30, 31], [5, 6]] = True  # a diagonal pair: one target
    hits[40, 20] = True  # alone
    labels = target_labels(hits)
    assert len(np.unique(labels[hits])) == 3
    assert len({labels[71, 10], labels[0, 10], labels[1, 10], labels[0, 11]}) == 1
    assert labels[30, 5] == labels[31, 6] != labels[40, 20]
    assert (labels[~hits] == -1).all()


def test_a_target_has_one_power_weighted_centre():
    """Three cells at one range across the seam: the centre is the circular mean azimuth,
    pulled towards the strongest cell; the cells, not the noise, carry the target."""
    power = np.full((72, 25), 0.01, np.float32)
    power[[71, 0, 1], 10] = [10.0, 20.0, 10.0]
    power[0, 11] = 2.0
    geometry = PolarGeometry(0.0, 2 * np.pi / 72, 0.0, 4.0)
    detector = CfarDetector.from_config(CfarConfig(false_alarm_rate=1e-3))
    found, targets = detect(power, geometry, detector)
    assert len(targets) == 1 and len(found) == 4 and (found.target == 0).all()
    assert targets.azimuth_rad[0] == pytest.approx(0.0, abs=1e-6)
    expected_range = (42.0 * 40.0 + 46.0 * 2.0) / 42.0
    assert targets.range_m[0] == pytest.approx(expected_range, rel=1e-5)
    assert (targets.peak_beam[0], targets.peak_cell[0], targets.num_cells[0]) == (0, 10, 4)
    assert targets.power[0] == pytest.approx(42.0)


def test_wrong_reflectance_size_is_refused():
    msg = radar_image_msg(np.zeros((4, 10), np.float32))
    msg["num_cells"] = 11
    with pytest.raises(ValueError, match="reflectance"):
        radar_power(msg)
