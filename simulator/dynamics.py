"""Vessel dynamics: the 3-DOF surge/sway/yaw model of thesis eq. 2.1.1-2.1.2, RK4 at a fixed rate.

State: position (x, y) and heading psi in the map frame; surge u, sway v (over ground, body
frame) and yaw rate r. Inputs: surge force tau_u and yaw moment tau_r (the vessel is
under-actuated: no sway force). Damping acts on the velocity relative to the water (current);
wind adds a quadratic drag disturbance tau_w. Two deliberate deviations from the printed
equations, which carry extraction typos: the sway Coriolis term is -m11 u r (the sign that makes
M nu_dot + C(nu) nu consistent with the printed yaw term), and the quadratic yaw damping is
divided by m33, not m11.

Collisions: before a step is accepted, short rays are cast from the hull outline along the
motion; if one hits terrain or an object the vessel stops there instead of passing through.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from schemas.values import Message
from simulator.config import VesselConfig
from simulator.frames import Pose2D, rotation_z, wrap_angle_rad
from simulator.scene import Scene

__all__ = ["Command", "Pose2D", "StepResult", "VesselDynamics", "VesselState"]

AIR_DENSITY_KGPM3 = 1.225  # ISA sea level


@dataclass(frozen=True)
class VesselState:
    """Pose in the map frame and body-frame velocities over ground."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0
    u_mps: float = 0.0
    v_mps: float = 0.0
    r_radps: float = 0.0

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x_m, self.y_m, self.yaw_rad)

    @classmethod
    def at(cls, pose: Pose2D) -> VesselState:
        return cls(pose.x_m, pose.y_m, pose.yaw_rad)

    def as_array(self) -> np.ndarray:
        return np.array([self.x_m, self.y_m, self.yaw_rad, self.u_mps, self.v_mps, self.r_radps])


@dataclass(frozen=True)
class Command:
    """Actuator demand: surge force (N) and yaw moment (N m)."""

    surge_force_n: float = 0.0
    yaw_moment_nm: float = 0.0

    @classmethod
    def from_wrench(cls, wrench: Message) -> Command:
        """From a canonical geometry_msgs/msg/Wrench: force.x = surge, torque.z = yaw."""
        return cls(float(wrench["force"]["x"]), float(wrench["torque"]["z"]))


@dataclass(frozen=True)
class StepResult:
    """One physics step: the new state, body accelerations over ground, and whether it hit."""

    state: VesselState
    accel_body_mps2: tuple[float, float]  # d/dt of the inertial velocity, in body axes
    yaw_accel_radps2: float
    collided: bool


class VesselDynamics:
    """Integrates the vessel at `cfg.physics_rate_hz`; `scene` (optional) enables collisions."""

    def __init__(self, cfg: VesselConfig | None = None, scene: Scene | None = None) -> None:
        self.cfg = cfg or VesselConfig()
        self.scene = scene
        self.dt_s = 1.0 / self.cfg.physics_rate_hz
        c = self.cfg
        hx, hy = c.length_m / 2, c.beam_m / 2
        # Hull probe points (body frame, x forward): bow, corners and mid-sides, at the
        # waterline-draft middle and above the water, so banks, piers and hulls are all seen.
        outline = np.array([[hx, 0], [hx, hy], [hx, -hy], [0, hy], [0, -hy], [-hx, hy], [-hx, -hy]])
        heights = np.array([-c.draft_m / 2, 0.5])
        self._probes_body = np.column_stack(
            [np.tile(outline, (len(heights), 1)), np.repeat(heights, len(outline))]
        )

    def derivatives(self, state: np.ndarray, command: Command) -> np.ndarray:
        """d/dt of (x, y, psi, u, v, r) — eq. 2.1.1 and 2.1.2 with current and wind.

        Eq. 2.1.2 is applied to the velocity relative to the water (nu_r = nu - nu_c); the
        current, constant in the map frame, turns in body axes as the vessel yaws:
        nu_c_dot = (r v_c, -r u_c). So an idle vessel drifts with the current, unturned.
        """
        c = self.cfg
        _, _, psi, u, v, r = state
        cos, sin = np.cos(psi), np.sin(psi)
        current_e, current_n = c.current_velocity_mps
        uc, vc = cos * current_e + sin * current_n, -sin * current_e + cos * current_n
        ur, vr = u - uc, v - vc
        tau_wu, tau_wv = self._wind_force(psi, u, v)
        tau_u = np.clip(command.surge_force_n, -c.max_surge_force_n, c.max_surge_force_n)
        tau_r = np.clip(command.yaw_moment_nm, -c.max_yaw_moment_nm, c.max_yaw_moment_nm)
        dur = (
            c.m22_kg * vr * r - c.d_u * ur - c.d_u2 * abs(ur) * ur - c.d_u3 * ur**3 + tau_u + tau_wu
        ) / c.m11_kg
        dvr = (
            -c.m11_kg * ur * r - c.d_v * vr - c.d_v2 * abs(vr) * vr - c.d_v3 * vr**3 + tau_wv
        ) / c.m22_kg
        dr = (
            (c.m11_kg - c.m22_kg) * ur * vr
            - c.d_r * r
            - c.d_r2 * abs(r) * r
            - c.d_r3 * r**3
            + tau_r
            + c.wind_yaw_arm_m * tau_wv
        ) / c.m33_kgm2
        return np.array([u * cos - v * sin, u * sin + v * cos, r, dur + r * vc, dvr - r * uc, dr])

    def _wind_force(self, psi: float, u: float, v: float) -> tuple[float, float]:
        """Quadratic wind drag (surge, sway) in N from the wind relative to the moving hull."""
        c = self.cfg
        wind_e, wind_n = c.wind_velocity_mps
        if wind_e == 0.0 and wind_n == 0.0:
            return 0.0, 0.0
        cos, sin = np.cos(psi), np.sin(psi)
        wx = cos * wind_e + sin * wind_n - u
        wy = -sin * wind_e + cos * wind_n - v
        q = 0.5 * AIR_DENSITY_KGPM3 * c.wind_drag_coefficient
        return q * c.wind_area_front_m2 * abs(wx) * wx, q * c.wind_area_side_m2 * abs(wy) * wy

    def step(self, state: VesselState, command: Command) -> StepResult:
        """Advance one fixed step (classic RK4); stop at an obstacle instead of entering it."""
        h = self.dt_s
        s0 = state.as_array()
        k1 = self.derivatives(s0, command)
        k2 = self.derivatives(s0 + h / 2 * k1, command)
        k3 = self.derivatives(s0 + h / 2 * k2, command)
        k4 = self.derivatives(s0 + h * k3, command)
        s1 = s0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if self._blocked(s0, s1[:2] - s0[:2]):
            r = float(s1[5])
            stopped = VesselState(state.x_m, state.y_m, wrap_angle_rad(s1[2]), 0.0, 0.0, r)
            accel = (-state.u_mps / h, -state.v_mps / h)
            return StepResult(stopped, accel, (r - state.r_radps) / h, True)
        x, y, yaw, u, v, r = (float(value) for value in s1)
        new = VesselState(x, y, wrap_angle_rad(yaw), u, v, r)
        du, dv, dr = (s1[3:] - s0[3:]) / h
        # Inertial acceleration in body axes: nu_dot + omega x nu.
        accel = (du - s1[5] * s1[4], dv + s1[5] * s1[3])
        return StepResult(new, (float(accel[0]), float(accel[1])), float(dr), False)

    def _blocked(self, s0: np.ndarray, displacement_m: np.ndarray) -> bool:
        """True if any hull probe meets geometry within the step's travel plus the clearance."""
        distance = float(np.hypot(*displacement_m))
        if self.scene is None or distance == 0.0:
            return False
        rotation = rotation_z(s0[2])
        origins = self._probes_body @ rotation.T + [s0[0], s0[1], self.scene.water_level_m]
        direction = np.array([*displacement_m / distance, 0.0])
        reach = distance + self.cfg.collision_clearance_m
        dists = np.full(len(origins), reach, np.float32)
        hit = self.scene.embree.run(
            origins.astype(np.float32),
            np.tile(direction, (len(origins), 1)).astype(np.float32),
            dists=dists,
            query="DISTANCE",
        )
        return bool((hit < reach).any())
