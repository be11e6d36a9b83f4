"""Known-geometry scenes for the simulator tests (a module, not conftest, so that test folders
with helpers of their own never shadow each other on sys.path)."""

from __future__ import annotations

import numpy as np
import trimesh

from simulator.materials import Material
from simulator.props import MeshPart
from simulator.scene import Scene

WALL = Material("wall", radar_reflectance=7.0, lidar_reflectivity=0.8, colour_rgb=(200, 40, 30))


def box_part(lower, upper, material: Material = WALL) -> MeshPart:
    """An axis-aligned box from corner `lower` to corner `upper` (map frame, metres)."""
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    box = trimesh.creation.box(extents=upper - lower)
    box.apply_translation((lower + upper) / 2)
    return MeshPart(np.asarray(box.vertices), np.asarray(box.faces), material)


def box_scene(lower, upper, material: Material = WALL) -> Scene:
    """A scene holding one box and nothing else (no terrain, no water surface)."""
    return Scene([box_part(lower, upper, material)], water_level_m=0.0)
