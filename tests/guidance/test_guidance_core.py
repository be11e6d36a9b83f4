"""guidance's numeric core: the route, the corridor search, the loops and the pilot's modes."""

from __future__ import annotations

import numpy as np
import pytest

from guidance.avoidance import choose_heading, free_distance_m
from guidance.config import AvoidanceConfig, GuidanceConfig, InputsConfig
from guidance.path import Route
from guidance.pilot import Pilot, Situation, VesselPose

STRAIGHT = Route(np.array([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]]))
NO_OBSTACLES = np.zeros((0, 2))


def test_projection_gives_along_track_signed_cross_track_and_heading():
    where = STRAIGHT.project((150.0, 3.0))
    assert where.along_m == pytest.approx(150.0)
    assert where.cross_track_m == pytest.approx(3.0)  # left of the route is positive
    assert STRAIGHT.project((50.0, -2.0)).cross_track_m == pytest.approx(-2.0)
    bend = Route(np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]))
    assert bend.project((11.0, 5.0)).heading_rad == pytest.approx(np.pi / 2)
    assert bend.point_at(15.0) == pytest.approx((10.0, 5.0))
    assert bend.point_at(99.0) == pytest.approx((10.0, 10.0))  # clamped at the end


def test_a_route_needs_two_distinct_points():
    with pytest.raises(ValueError, match="n >= 2"):
        Route(np.array([[0.0, 0.0]]))
    with pytest.raises(ValueError, match="repeat"):
        Route(np.array([[0.0, 0.0], [0.0, 0.0]]))


def test_free_distance_is_the_first_obstacle_inside_the_corridor():
    obstacles = np.array([[30.0, 1.0], [60.0, -0.5], [20.0, 8.0], [-10.0, 0.0]])
    free = free_distance_m(obstacles, np.array([0.0, np.pi / 2, np.pi]), 2.0, 80.0)
    # ahead: (30, 1) is inside the 2 m corridor, (20, 8) is not; left: nothing; astern: 10 m
    assert free == pytest.approx([30.0, 80.0, 10.0])


def test_the_route_heading_is_kept_while_its_corridor_is_free():
    cfg = AvoidanceConfig()
    beside = np.array([[30.0, 15.0], [30.0, -15.0]])  # 15 m either side: clear of 11.25 m
    choice = choose_heading(beside, 0.0, None, cfg, half_beam_m=1.25)
    assert choice.heading_rad == pytest.approx(0.0)
    assert not choice.deviates and choice.speed_factor == 1.0


def test_an_obstacle_ahead_turns_the_heading_just_enough_to_clear_it():
    cfg = AvoidanceConfig()
    ahead = np.array([[40.0, y] for y in np.linspace(-2.0, 2.0, 9)])
    choice = choose_heading(ahead, 0.0, None, cfg, half_beam_m=1.25)
    assert choice.deviates and choice.speed_factor == 1.0
    # the corridor (clearance + half beam = 11.25 m) must pass the obstacle's near edge
    lateral_m = 40.0 * abs(np.sin(choice.heading_rad)) - 2.0 * abs(np.cos(choice.heading_rad))
    assert lateral_m >= cfg.clearance_m + 1.25
    assert abs(choice.heading_rad) < np.deg2rad(30.0)  # and no more than needed
    # hysteresis: having chosen a side, the same side stays cheaper
    again = choose_heading(ahead, 0.0, choice.heading_rad, cfg, half_beam_m=1.25)
    assert np.sign(again.heading_rad) == np.sign(choice.heading_rad)


def test_a_wall_ahead_slows_to_a_stop_at_the_stop_distance():
    cfg = AvoidanceConfig()
    wall = np.array([[x, y] for x in (12.0, 30.0) for y in np.linspace(-300.0, 300.0, 601)])
    choice = choose_heading(wall, 0.0, None, cfg, half_beam_m=1.25)
    assert choice.speed_factor == 0.0
    far_wall = wall[wall[:, 0] == 30.0]  # within 50 m along every heading of a 40 deg fan
    narrow = AvoidanceConfig(fan_deg=40.0)
    slowed = choose_heading(far_wall, 0.0, None, narrow, half_beam_m=1.25).speed_factor
    assert 0.0 < slowed < 1.0


def situation(**changes: object) -> Situation:
    base: dict[str, object] = {
        "pose": VesselPose(0.0, 0.0, 0.0, 3.5, 0.0),
        "pose_age_s": 0.0,
        "obstacles_m": NO_OBSTACLES,
        "input_age_s": 0.2,
        "manual": False,
        "dt_s": 0.1,
    }
    base.update(changes)
    return Situation(**base)  # type: ignore[arg-type]


def test_the_pilot_follows_then_slows_and_stops_on_stale_input():
    pilot = Pilot(GuidanceConfig(), STRAIGHT)
    inputs = InputsConfig()
    fresh = pilot.decide(situation())
    assert fresh.mode == "follow" and fresh.speed_mps == pytest.approx(3.5)
    halfway = (inputs.slow_age_s + inputs.stop_age_s) / 2
    slowing = pilot.decide(situation(input_age_s=halfway))
    assert slowing.mode == "stale" and slowing.speed_mps == pytest.approx(1.75)
    stopped = pilot.decide(situation(input_age_s=inputs.stop_age_s + 0.1))
    assert stopped.mode == "stale" and stopped.speed_mps == 0.0
    assert stopped.wrench is not None and stopped.wrench.surge_force_n < 0  # brakes
    never = pilot.decide(situation(input_age_s=None))
    assert never.speed_mps == 0.0


def test_the_pilot_stops_without_a_pose_and_stands_by_for_a_person():
    pilot = Pilot(GuidanceConfig(), STRAIGHT)
    assert pilot.decide(situation(pose=None)).mode == "stop"
    assert pilot.decide(situation(pose_age_s=5.0)).mode == "stop"
    manual = pilot.decide(situation(manual=True))
    assert manual.mode == "manual" and manual.wrench is None
    end = pilot.decide(situation(pose=VesselPose(195.0, 0.0, 0.0, 3.5, 0.0)))
    assert end.mode == "stop" and end.speed_mps == 0.0


def test_the_heading_loop_turns_towards_the_demand_and_damps_the_rate():
    pilot = Pilot(GuidanceConfig(), STRAIGHT)
    left_of_route = pilot.decide(situation(pose=VesselPose(50.0, 20.0, 0.0, 3.5, 0.0)))
    assert left_of_route.wrench is not None and left_of_route.wrench.yaw_moment_nm < 0
    spinning = pilot.decide(situation(pose=VesselPose(50.0, 0.0, 0.0, 3.5, 0.5)))
    assert spinning.wrench is not None and spinning.wrench.yaw_moment_nm < 0


def test_occupied_cells_boxes_and_targets_become_points_placed_with_the_pose_at_their_stamp():
    from guidance.messages import PoseHistory, box_obstacles, grid_obstacles, to_map

    origin = {"position": {"x": -1.0, "y": -0.5}}
    grid = {
        "info": {"width": 4, "height": 2, "resolution": 0.5, "origin": origin},
        "data": np.array([0, 100, -1, 0, 0, 0, 0, 100], dtype=np.int8),
    }
    # row 0 col 1 -> (-1 + 0.75, -0.5 + 0.25); row 1 col 3 -> (-1 + 1.75, -0.5 + 0.75)
    assert grid_obstacles(grid) == pytest.approx(np.array([[-0.25, -0.25], [0.75, 0.25]]))
    box = {"min": {"x": 10.0, "y": -1.0, "z": 0.0}, "max": {"x": 12.0, "y": 1.0, "z": 2.0}}
    high = {"min": {"x": 10.0, "y": -1.0, "z": 30.0}, "max": {"x": 12.0, "y": 1.0, "z": 31.0}}
    points = box_obstacles({"boxes": [box, high]}, (0.5, 0.0), max_z_m=20.0)
    assert len(points) == 5 and points[:, 0].min() == 10.5 and points[:, 0].max() == 12.5
    history = PoseHistory(capacity=4)
    for k in range(6):  # the oldest two fall out of the ring
        history.add(k * 1_000_000_000, VesselPose(float(k), 0.0, np.pi / 2, 0.0, 0.0))
    assert history.at(4_900_000_000) == pytest.approx((5.0, 0.0, np.pi / 2))
    # bow to the north (+y): 10 m ahead of the vessel at (5, 0) is (5, 10)
    assert to_map(np.array([[10.0, 0.0]]), (5.0, 0.0, np.pi / 2)) == pytest.approx(
        np.array([[5.0, 10.0]])
    )
