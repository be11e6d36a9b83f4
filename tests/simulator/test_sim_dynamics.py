"""Vessel dynamics: terminal speed, turning, current drift, collisions, wrench commands."""

from __future__ import annotations

import numpy as np
import pytest

from simulator.config import VesselConfig
from simulator.dynamics import Command, Pose2D, VesselDynamics, VesselState
from tests.simulator.sim_scenes import box_scene


def run(dynamics: VesselDynamics, state: VesselState, command: Command, seconds: float):
    result = None
    for _ in range(round(seconds * dynamics.cfg.physics_rate_hz)):
        result = dynamics.step(state, command)
        state = result.state
    return result


def terminal_surge_speed(cfg: VesselConfig, force_n: float) -> float:
    """Root of d_u u + d_u2 u^2 = tau (d_u3 = 0): the speed where damping balances thrust."""
    return (-cfg.d_u + np.sqrt(cfg.d_u**2 + 4 * cfg.d_u2 * force_n)) / (2 * cfg.d_u2)


@pytest.mark.parametrize("force_n", [500.0, 2000.0, 4000.0])
def test_constant_thrust_converges_to_the_analytic_terminal_speed(force_n):
    dynamics = VesselDynamics()
    result = run(dynamics, VesselState(), Command(force_n, 0.0), seconds=120.0)
    assert result.state.u_mps == pytest.approx(
        terminal_surge_speed(dynamics.cfg, force_n), rel=1e-6
    )
    assert result.state.v_mps == pytest.approx(0.0, abs=1e-12)
    assert result.state.y_m == pytest.approx(0.0, abs=1e-9)
    assert result.accel_body_mps2[0] == pytest.approx(0.0, abs=1e-6)


def test_commands_are_clipped_to_the_actuators():
    dynamics = VesselDynamics()
    clipped = run(dynamics, VesselState(), Command(1e6, 0.0), seconds=120.0)
    limit = dynamics.cfg.max_surge_force_n
    assert clipped.state.u_mps == pytest.approx(terminal_surge_speed(dynamics.cfg, limit))


def test_heading_north_moves_north():
    dynamics = VesselDynamics()
    result = run(dynamics, VesselState.at(Pose2D(0.0, 0.0, np.pi / 2)), Command(2000.0), 10.0)
    assert result.state.x_m == pytest.approx(0.0, abs=1e-9)
    assert result.state.y_m > 10.0


def test_steady_turn_balances_yaw_moment_and_damping():
    dynamics = VesselDynamics()
    cfg = dynamics.cfg
    result = run(dynamics, VesselState(), Command(0.0, 1500.0), seconds=60.0)
    r = result.state.r_radps
    # Without surge the Munk moment vanishes: tau_r = d_r r + d_r2 r^2.
    expected = (-cfg.d_r + np.sqrt(cfg.d_r**2 + 4 * cfg.d_r2 * 1500.0)) / (2 * cfg.d_r2)
    assert r == pytest.approx(expected, rel=1e-6)
    assert -np.pi <= result.state.yaw_rad < np.pi


def test_turning_with_way_on_accelerates_towards_the_centre():
    dynamics = VesselDynamics()
    result = run(dynamics, VesselState(), Command(2000.0, 1500.0), seconds=60.0)
    state = result.state
    # Steady state: inertial lateral acceleration is u r (centripetal, to port for r > 0).
    assert result.accel_body_mps2[1] == pytest.approx(state.u_mps * state.r_radps, rel=1e-3)
    assert result.accel_body_mps2[1] > 0


def test_current_carries_an_idle_vessel():
    dynamics = VesselDynamics(VesselConfig(current_velocity_mps=(0.5, -0.2)))
    state = run(dynamics, VesselState(), Command(), seconds=300.0).state
    c, s = np.cos(state.yaw_rad), np.sin(state.yaw_rad)
    over_ground = (c * state.u_mps - s * state.v_mps, s * state.u_mps + c * state.v_mps)
    assert over_ground == pytest.approx((0.5, -0.2), abs=1e-4)  # no velocity through the water
    assert state.r_radps == pytest.approx(0.0, abs=1e-6)


def test_head_wind_slows_the_vessel():
    calm = run(VesselDynamics(), VesselState(), Command(2000.0), 120.0).state.u_mps
    windy_cfg = VesselConfig(wind_velocity_mps=(-10.0, 0.0))
    windy = run(VesselDynamics(windy_cfg), VesselState(), Command(2000.0), 120.0).state.u_mps
    assert windy < calm - 0.05


def test_collision_stops_the_vessel_before_the_wall():
    wall_x_m = 30.0
    scene = box_scene((wall_x_m, -50.0, -10.0), (32.0, 50.0, 10.0))
    dynamics = VesselDynamics(scene=scene)
    state, collided = VesselState(), []
    for _ in range(60 * 50):
        result = dynamics.step(state, Command(4000.0))
        state = result.state
        collided.append(result.collided)
    bow_m = state.x_m + dynamics.cfg.length_m / 2
    assert any(collided)
    assert bow_m < wall_x_m
    assert bow_m > wall_x_m - 1.0  # it did get there
    assert state.u_mps == 0.0
    # Reversing away from the wall is allowed.
    backed = run(dynamics, state, Command(-2000.0), seconds=5.0)
    assert not backed.collided and backed.state.x_m < state.x_m


def test_no_collision_without_obstacles():
    scene = box_scene((30.0, 100.0, -10.0), (32.0, 150.0, 10.0))  # off to the side
    result = run(VesselDynamics(scene=scene), VesselState(), Command(4000.0), seconds=30.0)
    assert not result.collided and result.state.x_m > 40.0


def test_command_from_a_wrench_message():
    wrench = {
        "force": {"x": 1200.0, "y": 5.0, "z": 0.0},
        "torque": {"x": 0.0, "y": 0.0, "z": -300.0},
    }
    assert Command.from_wrench(wrench) == Command(1200.0, -300.0)


def test_vessel_driven_at_the_river_bank_stops_afloat(small_scene):
    start = small_scene.start_pose
    towards_bank = Pose2D(start.x_m, start.y_m, start.yaw_rad - np.pi / 2)  # starboard bank
    dynamics = VesselDynamics(scene=small_scene)
    result = run(dynamics, VesselState.at(towards_bank), Command(4000.0), seconds=60.0)
    state = result.state
    assert result.collided and state.u_mps == 0.0
    travelled_m = np.hypot(state.x_m - start.x_m, state.y_m - start.y_m)
    assert 20.0 < travelled_m < 60.0  # half the 90 m river, less the hull and shallow margin
    ground_m = small_scene.terrain.height_at(state.x_m, state.y_m)
    assert ground_m < small_scene.water_level_m  # still over water, not up the bank
