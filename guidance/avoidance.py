"""Obstacle avoidance on the obstacle map: the heading nearest the route's that has free water.

A fan of candidate headings around the vessel; for each, the distance to the first obstacle
point inside a corridor as wide as the hull plus the clearance on either side. The route's
heading is kept when its corridor is free for `need_m`; otherwise the closest free heading
(a small penalty for leaving the previous choice stops it flapping between sides); when
nothing is free, the heading with the most water and a speed that falls to zero at
`stop_distance_m`. One (points x headings) numpy broadcast per tick, no loop over cells.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guidance.config import AvoidanceConfig


@dataclass(frozen=True)
class Choice:
    """The heading to steer (map yaw), its free distance (m) and the speed factor (0..1)."""

    heading_rad: float
    free_m: float
    speed_factor: float
    deviates: bool  # True when the route's own heading was not free


def wrap_rad(angle_rad: np.ndarray | float) -> np.ndarray:
    """Angles wrapped into [-pi, pi)."""
    wrapped: np.ndarray = (np.asarray(angle_rad) + np.pi) % (2 * np.pi) - np.pi
    return wrapped


def free_distance_m(
    obstacles_m: np.ndarray, headings_rad: np.ndarray, half_width_m: float, range_m: float
) -> np.ndarray:
    """Free run along each heading: (k,) metres, `range_m` when the corridor is clear.

    obstacles_m : (n, 2) obstacle points relative to the vessel, map axes, metres
    headings_rad : (k,) map yaws
    The corridor starts at the vessel's reference point: what is abeam or astern never
    blocks a heading (a corridor reaching back past the stern stopped the vessel for good
    beside an obstacle it had come too close to; the stern's swing is in `margin_m`).
    """
    if len(obstacles_m) == 0:
        return np.full(len(headings_rad), range_m)
    directions = np.column_stack([np.cos(headings_rad), np.sin(headings_rad)])  # (k, 2)
    along = obstacles_m @ directions.T  # (n, k)
    lateral = np.abs(obstacles_m[:, :1] * directions[:, 1] - obstacles_m[:, 1:] * directions[:, 0])
    blocked = (along > 0.0) & (along < range_m) & (lateral < half_width_m)
    free: np.ndarray = np.where(blocked, along, range_m).min(axis=0)
    return free


def choose_heading(
    obstacles_m: np.ndarray,
    route_heading_rad: float,
    previous_rad: float | None,
    cfg: AvoidanceConfig,
    half_beam_m: float,
) -> Choice:
    """Pick the heading to steer for obstacles (n, 2) relative to the vessel (map axes)."""
    steps = int(cfg.fan_deg // cfg.fan_step_deg)
    offsets = np.deg2rad(cfg.fan_step_deg * np.arange(-steps, steps + 1))  # 0 in the middle
    headings = wrap_rad(route_heading_rad + offsets)
    near = np.hypot(obstacles_m[:, 0], obstacles_m[:, 1]) > cfg.ignore_within_m
    free = free_distance_m(
        obstacles_m[near],
        headings,
        cfg.clearance_m + cfg.margin_m + half_beam_m,
        cfg.range_m,
    )
    cost = np.abs(offsets)
    if previous_rad is not None:
        cost = cost + cfg.switch_penalty * np.abs(wrap_rad(headings - previous_rad))
    open_water = free >= cfg.need_m
    if open_water.any():
        k = int(np.argmin(np.where(open_water, cost, np.inf)))
        factor = 1.0
    else:
        k = int(np.argmax(free - 1e-3 * cost))  # the most water; the straighter on a tie
        span = cfg.need_m - cfg.stop_distance_m
        factor = float(np.clip((free[k] - cfg.stop_distance_m) / span, 0.0, 1.0))
    route_free = bool(open_water[steps])
    return Choice(float(headings[k]), float(free[k]), factor, not route_free)
