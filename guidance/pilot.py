"""One control tick as a pure function of what the vessel knows: route, pose, obstacles, ages.

The pilot decides the mode, the heading and speed to hold and the wrench that holds them:

- `follow`: the route's corridor is free; line of sight on the route at cruise speed.
- `avoid`: an obstacle is in the route's corridor; the nearest free heading
  (guidance.avoidance).
- `blocked`: no heading has `need_m` of free water; the freest one, slowing to a stop at
  `stop_distance_m`.
- `stale`: navigation's newest output is older than `slow_age_s`; slows linearly to a stop at
  `stop_age_s`.
- `stop`: no fresh pose, or the route's end; zero speed.
- `manual`: a person's /cmd_wrench within `operator_override_s`; commands nothing (the
  simulator applies the person's).

No clock, socket or message here: the edge (guidance.node) turns messages into a `Situation`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guidance.avoidance import choose_heading
from guidance.config import GuidanceConfig
from guidance.control import Controller, Wrench
from guidance.path import Route

MODES = ("follow", "avoid", "blocked", "stale", "stop", "manual")


@dataclass(frozen=True)
class VesselPose:
    """Map-frame pose and body velocities (the odometry)."""

    x_m: float
    y_m: float
    yaw_rad: float
    surge_mps: float
    yaw_rate_radps: float


@dataclass(frozen=True)
class Situation:
    """What one tick knows. obstacles_m : (n, 2) map-frame points; ages in seconds (None:
    never received); dt_s the time since the previous tick."""

    pose: VesselPose | None
    pose_age_s: float | None
    obstacles_m: np.ndarray
    input_age_s: float | None
    manual: bool
    dt_s: float


@dataclass(frozen=True)
class Decision:
    mode: str
    wrench: Wrench | None  # None in manual mode: publish nothing
    heading_rad: float
    speed_mps: float
    target_m: tuple[float, float]
    along_m: float
    cross_track_m: float
    free_m: float


class Pilot:
    """The route, the controller and the last heading chosen (for hysteresis)."""

    def __init__(self, cfg: GuidanceConfig, route: Route) -> None:
        self.cfg = cfg
        self.route = route
        self.controller = Controller(cfg.control)
        self._previous_rad: float | None = None

    def decide(self, now: Situation) -> Decision:
        cfg = self.cfg
        pose = now.pose
        if pose is None or now.pose_age_s is None or now.pose_age_s > cfg.inputs.pose_max_age_s:
            self.controller.reset()
            return Decision("stop", Wrench(0.0, 0.0), 0.0, 0.0, (0.0, 0.0), 0.0, 0.0, 0.0)
        where = self.route.project((pose.x_m, pose.y_m))
        target = self.route.point_at(where.along_m + cfg.route.lookahead_m)
        los_rad = float(np.arctan2(target[1] - pose.y_m, target[0] - pose.x_m))
        relative = now.obstacles_m - np.array([pose.x_m, pose.y_m])
        choice = choose_heading(
            relative, los_rad, self._previous_rad, cfg.avoidance, cfg.avoidance.beam_m / 2
        )
        self._previous_rad = choice.heading_rad
        mode = "avoid" if choice.deviates else "follow"
        factor = choice.speed_factor
        if factor < 1.0:
            mode = "blocked"
        freshness = self._freshness(now.input_age_s)
        if freshness < 1.0:
            mode, factor = "stale", min(factor, freshness)
        if where.along_m >= self.route.length_m - cfg.route.arrival_m:
            mode, factor = "stop", 0.0  # the route's end
        speed = cfg.speed.cruise_mps * factor
        if now.manual:
            self.controller.reset()
            return Decision(
                "manual", None, choice.heading_rad, 0.0, target, where.along_m,
                where.cross_track_m, choice.free_m,
            )  # fmt: skip
        wrench = self.controller.command(
            choice.heading_rad, pose.yaw_rad, pose.yaw_rate_radps, speed, pose.surge_mps, now.dt_s
        )
        return Decision(
            mode, wrench, choice.heading_rad, speed, target, where.along_m, where.cross_track_m,
            choice.free_m,
        )  # fmt: skip

    def _freshness(self, age_s: float | None) -> float:
        """1 while navigation's output is fresh, falling linearly to 0 at `stop_age_s`."""
        inputs = self.cfg.inputs
        if age_s is None:
            return 0.0
        span = inputs.stop_age_s - inputs.slow_age_s
        return float(np.clip((inputs.stop_age_s - age_s) / span, 0.0, 1.0))
