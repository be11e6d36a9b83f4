"""The pilot closing the loop on the simulator's 3-DOF model (no processes: the numeric cores
only): it holds the default route and passes an obstacle on it at the configured clearance."""

from __future__ import annotations

import numpy as np

from guidance.config import GuidanceConfig
from guidance.node import utm_route
from guidance.pilot import Pilot, Situation, VesselPose
from simulator.config import SceneConfig, VesselConfig
from simulator.dynamics import Command, VesselDynamics, VesselState
from simulator.valley import generate_valley

PHYSICS_PER_TICK = 5  # 50 Hz physics, 10 Hz control


def drive(obstacles_m: np.ndarray, seconds: float) -> tuple[np.ndarray, float]:
    """Positions (n, 2) at every tick and the route distance reached."""
    cfg = GuidanceConfig()
    route = utm_route(cfg)
    pilot, dynamics = Pilot(cfg, route), VesselDynamics(VesselConfig())
    heading = np.arctan2(*(route.points_m[1] - route.points_m[0])[::-1])
    state = VesselState(*route.points_m[0], yaw_rad=float(heading))
    track, along = [], 0.0
    for _ in range(int(seconds * 10)):
        pose = VesselPose(state.x_m, state.y_m, state.yaw_rad, state.u_mps, state.r_radps)
        seen = obstacles_m[np.hypot(*(obstacles_m - [state.x_m, state.y_m]).T) < 100.0]
        decision = pilot.decide(Situation(pose, 0.0, seen, 0.3, False, 0.1))
        assert decision.wrench is not None
        command = Command(decision.wrench.surge_force_n, decision.wrench.yaw_moment_nm)
        for _ in range(PHYSICS_PER_TICK):
            state = dynamics.step(state, command).state
        track.append((state.x_m, state.y_m))
        along = decision.along_m
    return np.array(track), along


def test_the_default_route_is_the_default_scenes_river():
    course = generate_valley(SceneConfig(terrain_cells=2), np.random.default_rng(7))[1]
    points = utm_route(GuidanceConfig()).points_m
    assert np.abs(points[:, 0] - course.centre_x_m(points[:, 1])).max() < 0.1


def test_the_loop_holds_the_route_and_passes_an_obstacle_at_the_clearance():
    cfg = GuidanceConfig()
    route = utm_route(cfg)
    centre = np.array(route.point_at(120.0))
    blob = centre + np.random.default_rng(1).uniform(-4.0, 4.0, (40, 2))  # a moored hull
    track, along = drive(blob, 70.0)
    assert along >= 200.0
    gaps = np.hypot(*(track[:, None, :] - blob[None]).T).min()
    assert gaps >= cfg.avoidance.clearance_m
    after = track[np.array([route.project(tuple(p)).along_m for p in track]) > 180.0]
    assert np.abs([route.project(tuple(p)).cross_track_m for p in after]).max() < 5.0
