"""Fixtures for the simulator tests: the procedural scene at test resolution."""

from __future__ import annotations

import pytest

from simulator.config import SceneConfig
from simulator.scene import Scene, build_scene


@pytest.fixture(scope="session")
def small_scene() -> Scene:
    """The procedural thesis scene at a coarse terrain resolution (fast to build)."""
    return build_scene(SceneConfig(terrain_cells=120, trees=20, houses=5), seed=3)
