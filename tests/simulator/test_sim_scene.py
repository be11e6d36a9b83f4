"""Terrain loaders, height-field meshes, and the procedural thesis scene."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from pydantic import ValidationError

from simulator import materials
from simulator.config import SceneConfig
from simulator.frames import Pose2D
from simulator.props import MeshPart
from simulator.scene import Scene, build_scene, deepest_water_pose
from simulator.terrain import (
    HeightField,
    heightfield_mesh,
    load_heightmap,
    load_xyz,
    save_xyz,
)


def test_xyz_round_trip(tmp_path):
    heights = np.arange(12, dtype=np.float32).reshape(3, 4) * 0.5 + 30.0
    field = HeightField(heights, 1.0, 384_000.0, 5_719_000.0)
    path = tmp_path / "dgm1.xyz"
    save_xyz(field, path)
    loaded = load_xyz(path)
    np.testing.assert_allclose(loaded.heights_m, heights, atol=1e-3)
    assert (loaded.spacing_m, loaded.origin_x_m, loaded.origin_y_m) == (1.0, 384_000.0, 5_719_000.0)


def test_xyz_lines_in_any_order_and_gaps(tmp_path):
    # Open-data style: x y z per line, here shuffled, 2 m spacing, one sample missing.
    lines = ["10 20 1.0", "12 22 4.0", "12 20 2.0", "14 20 3.0", "10 22 5.0"]
    path = tmp_path / "tile.xyz"
    path.write_text("\n".join(lines) + "\n")
    field = load_xyz(path)
    assert field.spacing_m == 2.0 and (field.origin_x_m, field.origin_y_m) == (10.0, 20.0)
    # Row 0 is the southern row y = 20; the missing (14, 22) takes the lowest height.
    np.testing.assert_array_equal(field.heights_m, [[1.0, 2.0, 3.0], [5.0, 4.0, 1.0]])


@pytest.mark.parametrize(("dtype", "full_scale"), [(np.uint8, 255), (np.uint16, 65535)])
def test_heightmap_images(tmp_path, dtype, full_scale):
    image = np.zeros((3, 5), dtype)
    image[0, :] = full_scale  # top row of the image = northern edge
    image[1, 2] = full_scale // 2
    path = tmp_path / "heightmap.png"
    assert cv2.imwrite(str(path), image)
    field = load_heightmap(path, spacing_m=2.0, height_range_m=(-4.0, 40.0))
    assert field.heights_m.shape == (3, 5) and field.spacing_m == 2.0
    np.testing.assert_allclose(field.heights_m[2], 40.0)  # north is the last row
    np.testing.assert_allclose(field.heights_m[0], -4.0)
    assert field.heights_m[1, 2] == pytest.approx(-4.0 + 44.0 * (full_scale // 2) / full_scale)


def test_heightmap_must_exist(tmp_path):
    with pytest.raises(ValueError, match="cannot read"):
        load_heightmap(tmp_path / "missing.png", 1.0, (0.0, 1.0))


def test_heightfield_mesh_and_bilinear_heights():
    rows, cols = 4, 6
    gx, gy = np.meshgrid(np.arange(cols) * 2.0, np.arange(rows) * 2.0)
    plane = (0.3 * gx - 0.1 * gy + 5.0).astype(np.float32)
    field = HeightField(plane, 2.0)
    vertices, faces = heightfield_mesh(field)
    assert vertices.shape == (rows * cols, 3) and faces.shape == (2 * (rows - 1) * (cols - 1), 3)
    v0, v1, v2 = (vertices[faces[:, k]] for k in range(3))
    assert np.all(np.cross(v1 - v0, v2 - v0)[:, 2] > 0)  # every normal points up
    x, y = np.array([1.3, 7.9, 3.0]), np.array([0.4, 5.5, 2.0])
    np.testing.assert_allclose(field.height_at(x, y), 0.3 * x - 0.1 * y + 5.0, rtol=1e-6)


def test_resampling_keeps_the_extent():
    field = HeightField(np.zeros((101, 201), np.float32), 1.0)
    coarse = field.resampled(50)
    assert coarse.extent_m == pytest.approx(field.extent_m)
    assert coarse.heights_m.shape == (26, 51)


def test_procedural_scene_is_deterministic_per_seed():
    cfg = SceneConfig(terrain_cells=40, trees=5, houses=2)
    a, b, c = build_scene(cfg, seed=1), build_scene(cfg, seed=1), build_scene(cfg, seed=2)
    np.testing.assert_array_equal(a.vertices, b.vertices)
    assert a.start_pose == b.start_pose
    assert a.vertices.shape != c.vertices.shape or not np.array_equal(a.vertices, c.vertices)


def test_thesis_scene_contents(small_scene):
    scene = small_scene
    f = scene.triangle_count
    assert scene.radar_reflectance.shape == (f,) and scene.radar_reflectance.dtype == np.float32
    assert scene.colour_rgb.shape == (f, 3) and scene.colour_rgb.dtype == np.uint8
    assert scene.lidar_reflectivity.shape == (f,)
    np.testing.assert_allclose(np.linalg.norm(scene.face_normals, axis=1), 1.0, atol=1e-5)
    # Two moored and two anchored vessels of 12 + 12 triangles each (hull and cabin boxes),
    # reflectance 100, and two buoys (12-sided drums, 48 triangles) as bright.
    assert np.count_nonzero(scene.radar_reflectance == materials.VESSEL.radar_reflectance) == 192
    assert materials.BUOY.radar_reflectance == materials.VESSEL.radar_reflectance
    # Five landing stages: a steel pontoon (12 triangles) each.
    assert np.count_nonzero(scene.radar_reflectance == materials.STEEL.radar_reflectance) == 60
    # One water quad, with the water's weak LIDAR return.
    assert np.count_nonzero(scene.lidar_reflectivity == materials.WATER.lidar_reflectivity) == 2


def test_start_pose_is_afloat_in_the_river(small_scene):
    pose = small_scene.start_pose
    depth_m = small_scene.water_level_m - small_scene.terrain.height_at(pose.x_m, pose.y_m)
    assert depth_m > 3.0
    # Looking along the river: open water for 50 m ahead.
    ahead = np.array([np.cos(pose.yaw_rad), np.sin(pose.yaw_rad), 0.0], np.float32)
    origin = np.array([pose.x_m, pose.y_m, small_scene.water_level_m + 0.5], np.float32)
    distance = small_scene.embree.run(origin[None], ahead[None], query="DISTANCE")
    assert distance[0] > 50.0


def test_water_obstacles_lie_ahead_in_range_and_leave_a_channel(small_scene):
    """Four obstacles up the river from the start pose, alternate sides of the centre line,
    within the radar's 100 m, each leaving >= 25 m of open water beside it (docs/quality.md)."""
    scene, pose = small_scene, small_scene.start_pose
    afloat = np.flatnonzero(scene.objects.on_water & (scene.objects.ids >= len(scene.objects) - 4))
    assert list(scene.objects.kinds[afloat]) == ["buoy", "buoy", "vessel", "vessel"]
    heading = np.array([np.cos(pose.yaw_rad), np.sin(pose.yaw_rad)])
    rel = scene.objects.centre_xyz[afloat, :2] - [pose.x_m, pose.y_m]
    ahead_m, left_m = rel @ heading, rel @ [-heading[1], heading[0]]
    assert np.all(ahead_m > 20.0) and np.all(np.hypot(*rel.T) < 95.0)
    # buoys at sites 0 and 2 on the left, anchored vessels at 1 and 3 on the right
    assert np.all(left_m[:2] > 5.0) and np.all(left_m[2:] < -5.0)
    for i in afloat:  # open water across the river beside each, to either bank
        centre, yaw = scene.objects.centre_xyz[i], scene.objects.yaw_rad[i]
        across = np.array([-np.sin(yaw), np.cos(yaw), 0.0], np.float32)
        half_beam = scene.objects.size_xyz[i, 1] / 2
        origins = np.array(
            [centre + across * (half_beam + 0.1), centre - across * (half_beam + 0.1)]
        )
        origins[:, 2] = scene.water_level_m + 0.3
        reach = scene.embree.run(
            origins.astype(np.float32), np.array([across, -across]), query="DISTANCE"
        )
        assert min(reach) >= 25.0, (scene.objects.kinds[i], reach)


def test_water_obstacles_are_a_setting_that_leaves_the_rest_of_the_scene():
    cfg = SceneConfig(terrain_cells=40, trees=5, houses=2)
    with_them, without = (
        build_scene(cfg, seed=1),
        build_scene(cfg.model_copy(update={"water_obstacles": 0}), seed=1),
    )
    assert len(with_them.objects) == len(without.objects) + 4
    np.testing.assert_array_equal(with_them.objects.centre_xyz[:-4], without.objects.centre_xyz)
    with pytest.raises(ValidationError, match="water_obstacles_offset_m"):
        SceneConfig(water_obstacles_offset_m=20.0)  # 45 - 20 - 1.3 m < 25 m beside it
    assert SceneConfig(water_obstacles=0, water_obstacles_offset_m=20.0).water_obstacles == 0


def test_default_scene_has_about_half_a_million_triangles():
    scene = build_scene()
    assert 450_000 < scene.triangle_count < 550_000


def test_loaded_terrain_scene(tmp_path):
    # A bowl 60 m across: the start pose is the deepest point, the water level 1 m above it.
    gx, gy = np.meshgrid(np.arange(61.0), np.arange(61.0))
    bowl = 0.01 * ((gx - 30) ** 2 + (gy - 40) ** 2)
    path = tmp_path / "bowl.xyz"
    save_xyz(HeightField(bowl.astype(np.float32), 1.0, 384_000.0, 5_719_000.0), path)
    scene = build_scene(SceneConfig(terrain_source=str(path), terrain_cells=60, water_level_m=5.0))
    assert scene.water_level_m == 5.0
    # Centred map frame: the bowl's bottom (30, 40) of a 60 m grid sits at (0, 10).
    assert (scene.start_pose.x_m, scene.start_pose.y_m) == pytest.approx((0.0, 10.0), abs=1.0)


def test_deepest_water_pose_needs_water():
    with pytest.raises(ValueError, match="no water"):
        deepest_water_pose(HeightField(np.ones((5, 5), np.float32), 1.0), water_level_m=0.0)


def test_scene_arrays_are_read_only(small_scene):
    for array in (small_scene.vertices, small_scene.radar_reflectance, small_scene.colour_rgb):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1


def test_scene_from_parts_keeps_each_part_material():
    lower = MeshPart(
        np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), materials.GRASS
    )
    upper = MeshPart(
        np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1]]), np.array([[0, 1, 2]]), materials.VESSEL
    )
    scene = Scene([lower, upper], water_level_m=0.0)
    np.testing.assert_array_equal(scene.faces, [[0, 1, 2], [3, 4, 5]])
    np.testing.assert_array_equal(scene.radar_reflectance, [0.5, 100.0])
    assert scene.start_pose == Pose2D(0.0, 0.0, 0.0)
    down = np.array([[0.2, 0.2, 5.0]], np.float32), np.array([[0.0, 0.0, -1.0]], np.float32)
    assert scene.embree.run(*down, output=1)["primID"][0] == 1  # the upper triangle first
