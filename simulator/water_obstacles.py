"""Obstacles on the water ahead of the start pose: buoys and anchored vessels (docs/quality.md).

They are what a vessel must avoid and what navigation's detection quality is judged on, so
they sit within LIDAR and radar range of the start pose, deterministically (no random draws:
the rest of the seeded scene stays as it was), and alternate sides of the river's centre line,
leaving an open channel beside each (SceneConfig checks its width).
"""

from __future__ import annotations

import numpy as np
import trimesh

from simulator import materials
from simulator.config import SceneConfig
from simulator.frames import Pose2D
from simulator.objects import SceneObjects
from simulator.props import Props, box_mesh, instanced_part, objects_of
from simulator.valley import RiverCourse

# A buoy: a 1.5 m steel drum floating 1.8 m proud of the water (0.7 m below it).
BUOY_RADIUS_M = 0.75
BUOY_HEIGHT_M = 2.5
BUOY_DRAFT_M = 0.7


def obstacle_sites(
    cfg: SceneConfig, course: RiverCourse, start: Pose2D
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (k, 3), yaws (k,) and sides (k,: +1 left of the flow, -1 right) of the
    obstacles: the i-th `first_ahead + i * spacing` metres up the river (map y) from the start,
    `offset_m` off the centre line, on the left for even i and on the right for odd i."""
    k = cfg.water_obstacles
    along_m = cfg.water_obstacles_first_ahead_m + np.arange(k) * cfg.water_obstacles_spacing_m
    y = start.y_m + along_m
    yaw = course.heading_rad(y)
    side = np.where(np.arange(k) % 2 == 0, 1.0, -1.0)
    left = np.column_stack([-np.sin(yaw), np.cos(yaw)])
    xy = (
        np.column_stack([course.centre_x_m(y), y])
        + left * (side * cfg.water_obstacles_offset_m)[:, None]
    )
    return np.column_stack([xy, np.full(k, course.water_level_m)]), yaw, side


def water_obstacles(
    cfg: SceneConfig, course: RiverCourse, start: Pose2D, first_id: int = 0
) -> Props:
    """Buoys (sites 0, 2, ..) and anchored vessels (sites 1, 3, ..) at `obstacle_sites`:
    the buoys are objects first_id .., the vessels follow; all are on-water objects."""
    positions, yaws, _ = obstacle_sites(cfg, course, start)
    is_buoy = np.arange(len(positions)) % 2 == 0
    buoys = _buoys(positions[is_buoy], yaws[is_buoy], first_id)
    vessels = _anchored_vessels(positions[~is_buoy], yaws[~is_buoy], first_id + int(is_buoy.sum()))
    return Props(buoys.parts + vessels.parts, buoys.objects.concat(vessels.objects))


def _buoys(positions: np.ndarray, yaws: np.ndarray, first_id: int) -> Props:
    """Steel drums at `positions` (k, 3) on the water, objects first_id .."""
    if not len(positions):
        return Props([], SceneObjects.empty())
    drum = trimesh.creation.cylinder(radius=BUOY_RADIUS_M, height=BUOY_HEIGHT_M, sections=12)
    drum.apply_translation((0.0, 0.0, BUOY_HEIGHT_M / 2 - BUOY_DRAFT_M))
    parts = [instanced_part(drum, materials.BUOY, positions, yaws, first_id=first_id)]
    return Props(parts, objects_of("buoy", parts, positions, yaws, first_id, on_water=True))


def _anchored_vessels(positions: np.ndarray, yaws: np.ndarray, first_id: int) -> Props:
    """Small vessels (the moored ones' hull and cabin) riding at anchor, bow up the river."""
    if not len(positions):
        return Props([], SceneObjects.empty())
    forward = np.column_stack([np.cos(yaws), np.sin(yaws), np.zeros_like(yaws)])
    parts = [
        instanced_part(
            box_mesh(8.0, 2.6, 1.6, -0.6), materials.VESSEL, positions, yaws, None, first_id
        ),
        instanced_part(
            box_mesh(3.0, 2.0, 1.5, 1.0),
            materials.VESSEL,
            positions + forward,
            yaws,
            None,
            first_id,
        ),
    ]
    return Props(parts, objects_of("vessel", parts, positions, yaws, first_id, on_water=True))
