"""The report's closed-loop and mission figures on synthetic spans and tracks (docs/guidance.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clients.report.closed_loop import closed_loop
from clients.report.journeys import SpanRecord
from clients.report.mission import (
    AutopilotSeen,
    Footprints,
    hull_clearance_m,
    mission,
    route_distance_m,
)
from clients.report.results import json_ready

MS = 1_000_000
CMD = "/guidance/cmd_wrench"


def span(topic: str, stamp: int, stage: str, process: str, start: int, end: int) -> SpanRecord:
    return SpanRecord(topic, stamp, stage, process, "", start, end, 0, 0)


def scan_to_command(scan: int, processed: int, decoded: int, command: int, applied: int) -> list:
    """One LIDAR scan's way: navigation's process, guidance's decode and guide, the
    simulator's actuate (ms after 0)."""
    return [
        span("/lidar/points", scan * MS, "process", "navigation", scan * MS, processed * MS),
        span("/nav/boxes", scan * MS, "decode", "guidance", processed * MS, decoded * MS),
        span("/lidar/points", scan * MS, "guide", "guidance", decoded * MS, command * MS),
        span(CMD, command * MS, "encode", "guidance", command * MS, command * MS),
        span(CMD, command * MS, "actuate", "simulator", command * MS, applied * MS),
    ]


def test_perception_to_actuation_joins_the_four_recorders():
    spans = scan_to_command(1000, 1100, 1110, 1150, 1170)
    spans += scan_to_command(1500, 1620, 1625, 1650, 1660)
    spans += [span(CMD, t * MS, "encode", "guidance", t * MS, t * MS) for t in (1050, 1250)]
    loop = closed_loop(spans)
    assert loop is not None
    lidar = loop.perception_to_actuation_ms["/lidar/points"]
    assert (lidar.n, lidar.mean, lidar.max) == (2, 165.0, 170.0)
    assert loop.hops_ms["/lidar/points"] == pytest.approx(
        {"navigation": 110.0, "to_guidance": 7.5, "guidance": 32.5, "to_actuation": 15.0}
    )
    # commands at 1050, 1150, 1250, 1650 ms: periods 100, 100, 400
    assert loop.commands == 4
    assert loop.control_period_ms.mean == pytest.approx(200.0)
    assert loop.control_jitter_ms == pytest.approx(float(np.std([100, 100, 400])))
    document = json_ready(loop)
    assert list(document["perception_to_actuation_ms"]["/lidar/points"]) == [
        "mean",
        "p50",
        "p99",
        "max",
    ]


def test_no_applied_command_means_no_closed_loop():
    assert closed_loop(scan_to_command(1000, 1100, 1110, 1150, 1170)[:3]) is None


def footprint(x: float, y: float, length: float, beam: float, yaw: float = 0.0) -> Footprints:
    return Footprints(np.array([[x, y]]), np.array([[length / 2, beam / 2]]), np.array([yaw]))


def test_clearance_between_hull_and_objects_is_exact_for_rectangles():
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, np.pi / 2]])
    beside = footprint(0.0, 10.0, 8.0, 2.0)  # its near side at y = 9
    clearance = hull_clearance_m(poses, 7.0, 2.5, beside)
    # along x the hull's side is at y = 1.25; turned, its bow is at y = 3.5
    assert clearance == pytest.approx([9.0 - 1.25, 9.0 - 3.5])
    diamond = footprint(10.0, 10.0, 2.0, 2.0, yaw=np.pi / 4)  # corners on its axes
    gap = hull_clearance_m(poses[:1], 7.0, 2.5, diamond)[0]
    # closest pair: the diamond's lower corner (10, 10 - sqrt 2) and the hull's (3.5, 1.25)
    assert gap == pytest.approx(np.hypot(10.0 - 3.5, 10.0 - np.sqrt(2.0) - 1.25))


def test_route_distance_is_to_the_nearest_segment():
    route = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    points = np.array([[5.0, 2.0], [12.0, 5.0], [-3.0, 4.0]])
    assert route_distance_m(route, points) == pytest.approx([2.0, 2.0, 5.0])


def odometry(x: float, y: float) -> dict:
    return {"pose": {"pose": {"position": {"x": x, "y": y}, "orientation": {"z": 0.0, "w": 1.0}}}}


def status(collisions: int) -> dict:
    return {"status": [{"values": [{"key": "collisions", "value": str(collisions)}]}]}


def test_the_mission_from_track_route_truth_and_status():
    path = {"poses": [{"pose": {"position": {"x": x, "y": 0.0}}} for x in (0.0, 100.0)]}
    truth = {
        "markers": [
            {
                "pose": {"position": {"x": 50.0, "y": 20.0}, "orientation": {"z": 0.0, "w": 1.0}},
                "scale": {"x": 4.0, "y": 4.0, "z": 1.0},
            }
        ]
    }
    seen = AutopilotSeen(
        odometry=[odometry(x, 3.0) for x in np.arange(0.0, 61.0, 1.0)],
        path=path,
        ground_truth=truth,
        status=[status(2), status(3)],
    )
    result = mission(seen)
    assert result is not None
    assert result.distance_m == pytest.approx(60.0)
    assert result.cross_track_rms_m == pytest.approx(3.0)
    assert result.min_clearance_m == pytest.approx(18.0 - 3.0 - 1.25)
    assert result.collisions == 1
    assert list(json_ready(result)) == [
        "distance_m",
        "cross_track_rms_m",
        "min_clearance_m",
        "collisions",
    ]
    assert mission(AutopilotSeen(odometry=[odometry(0, 0)], path=path)) is None
    assert math.isnan(mission(AutopilotSeen(odometry=seen.odometry)).min_clearance_m)
