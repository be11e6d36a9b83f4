"""Detection quality: the matching on hand-made messages, then the real simulator and
navigation on the default scene against the issue's targets (docs/quality.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clients.report.quality import (
    LAND,
    LIDAR_MIN_RETURNS,
    NO_RETURN,
    TARGET_PRECISION,
    WATER,
    inside_objects,
    lidar_quality,
    lidar_scan_counts,
    pair_by_stamp,
    radar_quality,
    radar_sweep_counts,
    shortfalls,
)
from clients.report.results import ClassCounts, LidarCounts, RadarCounts


def header(sec: int, frame: str = "lidar") -> dict:
    return {"stamp": {"sec": sec, "nanosec": 0}, "frame_id": frame}


def obj(
    id_: int, center, size, yaw=0.0, returns=50, range_m=None, dominant=0, on_water=False
) -> dict:
    x, y, z = center
    return {
        "id": id_,
        "kind": "buoy" if on_water else "tree",
        "on_water": on_water,
        "center": {"x": x, "y": y, "z": z},
        "yaw_rad": yaw,
        "size": dict(zip("xyz", size, strict=True)),
        "returns": returns,
        "range_m": math.hypot(x, y) if range_m is None else range_m,
        "dominant_cells": dominant,
    }


def box(lo, hi) -> dict:
    return {
        "cluster_id": 0,
        "num_points": 10,
        "min": dict(zip("xyz", lo, strict=True)),
        "max": dict(zip("xyz", hi, strict=True)),
    }


def test_a_box_centre_inside_a_turned_object_grown_by_the_margin():
    turned = obj(0, (10.0, 0.0, 0.0), (8.0, 2.0, 2.0), yaw=np.pi / 2)  # long side along y
    centres = np.array(
        [
            [10.0, 3.9, 0.0],  # inside along the object's length
            [13.9, 0.0, 0.0],  # 3.9 m across: beyond 1 m + 1 m margin
            [11.9, 0.0, 0.0],  # 1.9 m across: inside the margin
            [10.0, 0.0, 2.5],
        ]
    )  # above the top, beyond the margin
    np.testing.assert_array_equal(
        inside_objects(centres, [turned], 1.0)[:, 0], [True, False, True, False]
    )


def test_lidar_boxes_count_per_class_and_only_on_objects_with_enough_returns():
    truth = {
        "header": header(1),
        "water_z_m": -3.0,
        "objects": [
            obj(0, (20.0, 0.0, -2.0), (2.0, 2.0, 2.0), on_water=True),  # found by a box
            obj(1, (0.0, 30.0, -2.0), (8.0, 3.0, 2.0), on_water=True),  # visible, missed
            obj(2, (0.0, -30.0, 0.0), (4.0, 4.0, 6.0), returns=9),  # too few returns to count
            obj(3, (150.0, 0.0, 0.0), (4.0, 4.0, 6.0)),  # beyond the evaluation range
            obj(4, (-20.0, 20.0, 1.0), (4.0, 4.0, 6.0)),  # a tree, found
        ],
    }
    boxes = {
        "header": header(1),
        "boxes": [
            box((19.0, -1.0, -3.0), (21.0, 1.0, -1.0)),  # on the buoy
            box((20.0, 1.0, -3.0), (22.0, 3.0, -1.0)),  # on it too, within the margin
            box((50.0, 50.0, -2.9), (51.0, 51.0, -2.0)),  # at the water, on nothing
            box((50.0, 60.0, 0.0), (51.0, 61.0, 1.0)),  # above the water, on nothing
            box((-1.0, -31.0, 0.0), (1.0, -29.0, 1.0)),  # on object 2: 9 returns, false
            box((151.0, 0.0, 0.0), (152.0, 1.0, 1.0)),  # on object 3: true, far
            box((-21.0, 19.0, 0.0), (-19.0, 21.0, 2.0)),  # on the tree
        ],
    }
    assert lidar_scan_counts(truth, boxes) == LidarCounts(
        boxes=7,
        on_water=ClassCounts(detections=3, true_detections=2, objects=2, detected_objects=1),
        bank=ClassCounts(detections=4, true_detections=2, objects=1, detected_objects=1),
    )
    quality = lidar_quality([(truth, boxes), (truth, boxes)])
    assert quality.scans == 2 and quality.boxes == 14
    assert quality.on_water.precision == pytest.approx(2 / 3)
    assert quality.on_water.recall == pytest.approx(0.5)
    assert quality.bank.precision == pytest.approx(0.5) and quality.bank.recall == 1.0
    assert shortfalls(quality) == [
        "on_water precision 0.667 < 0.9",
        "on_water recall 0.500 < 0.8",
    ]


def test_radar_targets_are_judged_by_their_strongest_cell():
    source = np.full((4, 5), WATER, np.int32)
    source[:, 0] = NO_RETURN
    source[1, 3] = 7  # a buoy dominates one cell
    source[2, 2:4] = LAND
    source[0, 4] = 9  # a tree
    truth = {
        "header": header(2, "radar"),
        "num_beams": 4,
        "num_cells": 5,
        "cell_source": source.reshape(-1),
        "objects": [
            obj(7, (12.0, 0.0, 0.0), (2.0, 2.0, 2.0), dominant=1, on_water=True),
            obj(8, (30.0, 0.0, 0.0), (2.0, 2.0, 2.0), dominant=0, on_water=True),
            obj(9, (16.0, 4.0, 0.0), (2.0, 2.0, 2.0), dominant=1),
        ],
    }

    def det(beam, cell, target):
        return {"beam": beam, "cell": cell, "target": target}

    detections = {
        "header": header(2, "radar"),
        "false_alarm_rate": 0.1,
        "detections": [det(1, 3, 0), det(1, 4, 0), det(2, 2, 1), det(3, 1, 2)],
        "targets": [
            {"peak_beam": 1, "peak_cell": 3},  # on the buoy
            {"peak_beam": 2, "peak_cell": 2},  # on bare land: no obstacle
            {"peak_beam": 3, "peak_cell": 1},  # on open water: false
        ],
    }
    counts = radar_sweep_counts(truth, detections)
    assert counts == RadarCounts(
        targets=3,
        on_water=ClassCounts(detections=2, true_detections=1, objects=1, detected_objects=1),
        bank=ClassCounts(detections=1, true_detections=0, objects=1, detected_objects=0),
        on_land=1,
        on_open_water=1,
        open_water_cells=16,
        open_water_detections=2,
    )
    quality = radar_quality([(truth, detections)])
    assert quality.on_water.precision == 0.5 and quality.on_water.recall == 1.0
    assert quality.bank.precision == 0.0 and quality.bank.recall == 0.0
    assert quality.open_water_false_alarm_rate == pytest.approx(2 / 16)
    assert quality.configured_false_alarm_rate == pytest.approx(0.1)
    assert shortfalls(quality) == [
        "on_water precision 0.500 < 0.9",
        "open-water false alarms 0.1250 > P_fa 0.1",
    ]


def test_pairs_need_the_same_stamp_and_no_pairs_give_no_figure():
    truths = [{"header": header(s)} for s in (1, 2, 3)]
    outputs = [{"header": header(s)} for s in (3, 1, 5)]
    assert [t["header"]["stamp"]["sec"] for t, _ in pair_by_stamp(truths, outputs)] == [1, 3]
    assert math.isnan(lidar_quality([]).on_water.precision) and radar_quality([]).sweeps == 0
    assert shortfalls(lidar_quality([])) == [
        "on_water precision nan < 0.9",
        "on_water recall nan < 0.8",
    ]


def sense(
    profile: str, poses_after_start: list | None = None, reduce_voxel_m: float | None = None
) -> tuple[list, list]:
    """(lidar pairs, radar pairs) of (truth, navigation output) from the real simulator and
    navigation cores (no sockets) on the default scene, at the start pose and `poses`; with
    `reduce_voxel_m`, navigation reads each scan as the bridge's `reduce` thins it."""
    from bridge.reduction import CloudReducer
    from navigation.config import LidarConfig as NavLidar
    from navigation.config import NavigationConfig
    from navigation.lidar_worker import ThreadLidarWorker
    from navigation.processors import Processors
    from simulator.config import SimConfig
    from simulator.lidar import Lidar
    from simulator.radar import Radar
    from simulator.scene import build_scene
    from simulator.truth import lidar_truth, radar_truth

    cfg = SimConfig(profile=profile)
    scene = build_scene(cfg.scene, seed=cfg.seed)
    nav = Processors(NavigationConfig(), ThreadLidarWorker(NavLidar()))
    lidar, radar = Lidar(cfg.lidar), Radar(cfg.radar)
    lidar_pairs, radar_pairs = [], []
    try:
        for k, pose in enumerate([scene.start_pose, *(poses_after_start or [])]):
            stamp = (k + 1) * 10**9
            scan = lidar.scan_with_sources(scene, pose)
            cloud = lidar.message(scan.points, stamp)
            if reduce_voxel_m is not None:
                cloud, _ = CloudReducer(cloud).reduced(reduce_voxel_m)
            [(_, boxes), _] = nav.lidar(cloud).outputs
            lidar_pairs.append((lidar_truth(scene, cfg.lidar, pose, scan.source, stamp), boxes))
            sweep = radar.sweep_with_sources(scene, pose)
            [(_, detections)] = nav.radar(radar.message(sweep.image, stamp)).outputs
            radar_pairs.append((radar_truth(scene, cfg.radar, pose, sweep, stamp), detections))
    finally:
        lidar.close()
        radar.close()
    return lidar_pairs, radar_pairs


@pytest.fixture(scope="module")
def start_pose_truth() -> tuple[dict, dict]:
    """The simulator's LIDAR and radar truth at the start pose of the default scene."""
    lidar_pairs, radar_pairs = sense("default")
    return lidar_pairs[0][0], radar_pairs[0][0]


def boxes_on(objects: list[dict], extra: list[dict] = ()) -> dict:
    """A fake LIDAR detector's output: one box exactly on each object, plus `extra`."""
    items = []
    for o in objects:
        c, half = o["center"], {k: v / 2 for k, v in o["size"].items()}
        lo = {k: c[k] - half[k] * (1.0 if k == "z" else 0.5) for k in "xyz"}
        hi = {k: c[k] + half[k] * (1.0 if k == "z" else 0.5) for k in "xyz"}
        items.append({"cluster_id": 0, "num_points": 20, "min": lo, "max": hi})
    return {"header": header(1), "boxes": items + list(extra)}


def water_grid_boxes(water_z_m: float) -> list[dict]:
    """Boxes every 10 m over the water surface within 100 m: what flags every wave."""
    xs = np.arange(-95.0, 96.0, 10.0)
    return [
        box((x, y, water_z_m), (x + 1.0, y + 1.0, water_z_m + 0.3))
        for x in xs
        for y in xs
        if math.hypot(x, y) <= 100.0
    ]


def targets_on(truth: dict, cells: np.ndarray) -> dict:
    """A fake radar detector's output: every cell of `cells` (beams, cells) bool detected,
    each its own target."""
    beams, ranges = np.nonzero(cells)
    return {
        "header": header(1, "radar"),
        "false_alarm_rate": 0.1,
        "detections": [
            {"beam": int(b), "cell": int(c), "target": i}
            for i, (b, c) in enumerate(zip(beams, ranges, strict=True))
        ],
        "targets": [
            {"peak_beam": int(b), "peak_cell": int(c)} for b, c in zip(beams, ranges, strict=True)
        ],
    }


def test_a_lidar_detector_that_boxes_only_the_banks_misses_the_target(start_pose_truth):
    truth, _ = start_pose_truth
    bank = [o for o in truth["objects"] if not o["on_water"] and o["returns"] >= LIDAR_MIN_RETURNS]
    quality = lidar_quality([(truth, boxes_on(bank))])
    assert quality.bank.precision == 1.0 and quality.bank.recall == 1.0
    assert quality.on_water.recall == 0.0 and quality.on_water.counts.objects >= 4
    assert shortfalls(quality)


def test_a_lidar_detector_that_boxes_everything_misses_the_target(start_pose_truth):
    truth, _ = start_pose_truth
    waves = water_grid_boxes(float(truth["water_z_m"]))
    quality = lidar_quality([(truth, boxes_on(truth["objects"], waves))])
    assert quality.on_water.recall == 1.0 and quality.on_water.precision < 0.2
    assert shortfalls(quality) == [
        f"on_water precision {quality.on_water.precision:.3f} < {TARGET_PRECISION}"
    ]


def test_a_radar_detector_that_flags_only_the_banks_misses_the_target(start_pose_truth):
    _, truth = start_pose_truth
    source = np.asarray(truth["cell_source"]).reshape(truth["num_beams"], truth["num_cells"])
    bank_ids = [o["id"] for o in truth["objects"] if not o["on_water"]]
    quality = radar_quality(
        [(truth, targets_on(truth, (source == LAND) | np.isin(source, bank_ids)))]
    )
    assert quality.bank.recall == 1.0 and quality.on_land > 0
    assert quality.on_water.counts.detections == 0 and quality.on_water.recall == 0.0
    assert quality.on_water.counts.objects >= 4
    assert shortfalls(quality)


def test_a_radar_detector_that_flags_every_cell_misses_the_target(start_pose_truth):
    _, truth = start_pose_truth
    everything = np.ones((truth["num_beams"], truth["num_cells"]), bool)
    quality = radar_quality([(truth, targets_on(truth, everything))])
    assert quality.on_water.recall == 1.0 and quality.on_water.precision < 0.01
    assert quality.open_water_false_alarm_rate == 1.0
    assert len(shortfalls(quality)) == 2


@pytest.mark.parametrize("profile", ["default", "thesis"])
def test_navigation_meets_the_on_water_targets_on_the_default_scene(profile):
    """The issue's targets for obstacles on the water, from the real simulator and navigation
    cores (no sockets): on_water precision >= 0.9 and recall >= 0.8 for LIDAR boxes and
    radar targets, radar false cells on open water at most the configured P_fa; at the start
    pose (the report's, with the four water obstacles ahead within 100 m: every one seen by
    both sensors) and, for the default profile, two more poses along the river, by a landing
    stage with a moored vessel and by another."""
    from simulator.frames import Pose2D

    more = [Pose2D(25.0, -690.0, 1.5), Pose2D(10.0, 300.0, 1.5)] if profile == "default" else []
    lidar_pairs, radar_pairs = sense(profile, more)
    start_lidar, start_radar = lidar_quality(lidar_pairs[:1]), radar_quality(radar_pairs[:1])
    assert start_lidar.on_water.counts.objects == start_radar.on_water.counts.objects == 4
    lidar_q, radar_q = lidar_quality(lidar_pairs), radar_quality(radar_pairs)
    assert shortfalls(lidar_q) == [], lidar_q
    assert shortfalls(radar_q) == [], radar_q
    assert radar_q.on_open_water == 0
    # the banks: every tree and house the sensors see well is found
    assert lidar_q.bank.recall >= 0.8 and radar_q.bank.recall >= 0.8


def test_navigation_detects_as_well_from_a_cloud_reduced_at_its_own_voxel_size():
    """A client asking `reduce: {"voxel_size": 0.2}` (navigation's own `voxel_size_m`) gets a
    cloud from which navigation finds the same objects as from the full one: precision and
    recall of both classes unchanged (docs/bridge.md, "Over a thin link")."""
    from navigation.config import LidarConfig
    from simulator.frames import Pose2D

    voxel_m = LidarConfig().voxel_size_m
    assert voxel_m == 0.2
    more = [Pose2D(25.0, -690.0, 1.5)]
    full, _ = sense("default", more)
    reduced, _ = sense("default", more, reduce_voxel_m=voxel_m)
    before, after = lidar_quality(full), lidar_quality(reduced)
    for kind in ("on_water", "bank"):
        was, now = getattr(before, kind), getattr(after, kind)
        assert (now.precision, now.recall) == (was.precision, was.recall), (kind, was, now)
    assert shortfalls(after) == []
