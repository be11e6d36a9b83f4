"""Heading and speed loops for the 3-DOF vessel (thesis eq. 2.1.1-2.1.2).

Heading: a PD law on the heading error with yaw-rate damping, tau_r = kp e - kd r. The hull
is directionally unstable at speed: its sway mass exceeds its surge mass (m22 3000 > m11 2200
kg), so the Munk moment (m11 - m22) u v of eq. 2.1.2 turns a small yaw further, faster than
yaw damping alone (d_r 3000 N m s) holds it. Gains from the linear yaw equation alone (kp 1500,
kd 2400 for omega_n 0.5 rad/s, zeta 0.9) let the vessel circle at 3.5 m/s. kp 6000 N m per
rad and kd 12000 N m s per rad hold the default route to a cross-track RMS of 0.36 m in the
3-DOF model (a sweep of kp 3000-12000 x kd 6000-24000 on it; docs/guidance.md); the yaw
moment saturates (6000 N m) beyond 1 rad of error, which is what a hard turn should do.

Speed: feed-forward of the surge damping at the demanded speed (d_u u + d_u2 |u| u: what holds
it there in still water) plus a PI on the speed error; kp 1100 N s/m on m11 2200 kg is a 2 s
time constant, ki 110 N/m removes what the model misses (current, wind) within ~20 s. The
integral is clamped to the actuator range (no wind-up while the thrust saturates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guidance.avoidance import wrap_rad
from guidance.config import ControlConfig


@dataclass(frozen=True)
class Wrench:
    """The command: surge force (N) and yaw moment (N m), already clipped to the actuators."""

    surge_force_n: float
    yaw_moment_nm: float


class Controller:
    """Both loops; holds the speed integral between ticks."""

    def __init__(self, cfg: ControlConfig) -> None:
        self.cfg = cfg
        self._speed_integral_n = 0.0

    def reset(self) -> None:
        """Forget the integral (after a stop or a manual override)."""
        self._speed_integral_n = 0.0

    def command(
        self,
        heading_rad: float,
        yaw_rad: float,
        yaw_rate_radps: float,
        speed_mps: float,
        surge_mps: float,
        dt_s: float,
    ) -> Wrench:
        """One tick: demanded heading and speed against the measured ones."""
        c = self.cfg
        error_rad = float(wrap_rad(heading_rad - yaw_rad))
        yaw = c.heading_kp * error_rad - c.heading_kd * yaw_rate_radps
        feed_forward = c.surge_damping_n_per_mps * speed_mps
        feed_forward += c.surge_damping_quadratic * abs(speed_mps) * speed_mps
        error_mps = speed_mps - surge_mps
        limit = c.max_surge_force_n
        self._speed_integral_n = float(
            np.clip(self._speed_integral_n + c.speed_ki * error_mps * dt_s, -limit, limit)
        )
        surge = feed_forward + c.speed_kp * error_mps + self._speed_integral_n
        if speed_mps == 0.0:
            surge = c.speed_kp * error_mps  # stopping: brake on the speed only, no integral
            self._speed_integral_n = 0.0
        return Wrench(
            float(np.clip(surge, -limit, limit)),
            float(np.clip(yaw, -c.max_yaw_moment_nm, c.max_yaw_moment_nm)),
        )
