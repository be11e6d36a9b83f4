"""LIDAR pipeline on a ray-cast river scene with known obstacles."""

from __future__ import annotations

import numpy as np
import pytest

from navigation.config import GroundConfig, LidarConfig
from navigation.lidar import obstacle_points, process_scan
from navigation.lidar_filter import estimate_water_level, range_mask, voxel_downsample
from navigation.lidar_messages import box_array_msg, marker_array_msg
from schemas.pointcloud import pack_points, view_points
from tests.navigation.nav_scenes import (
    BANK,
    NOISE,
    WATER,
    default_scene,
    lidar_directions,
    raycast,
    with_noise,
)

MARGIN_M = 0.35  # object points this close to water or terrain may go with the background


@pytest.fixture(scope="module")
def scan():
    """Full-resolution scan (thesis table 4.3: 0.25 deg, 345,600 rays) plus 300 noise returns.

    Coarser scans leave faces seen at a glancing angle too sparse for MinPts 10.
    """
    scene = default_scene()
    points, ids = raycast(scene, lidar_directions(0.25, 0.25))
    points, ids = with_noise(scene, points, ids, 300)
    return scene, points, ids


def clear_object_points(scene, points, ids, box_id):
    """Points of one box standing clear of water and terrain (what must be clustered)."""
    mask = ids == box_id
    z = points[:, 2]
    clear = z > np.maximum(scene.water_z_m, scene.bank_z_m(points[:, 1])) + MARGIN_M
    in_range = range_mask(points, LidarConfig().range_min_m, LidarConfig().range_max_m)
    return mask & clear & in_range


@pytest.mark.parametrize("voxel_size_m", [0.0, 0.2])
@pytest.mark.parametrize("adaptive", [False, True])
def test_every_object_is_one_cluster(scan, voxel_size_m, adaptive):
    scene, points, ids = scan
    config = LidarConfig(voxel_size_m=voxel_size_m, adaptive_eps=adaptive)
    result = process_scan(points, config)
    found = []
    for box_id in range(len(scene.boxes)):
        mask = clear_object_points(scene, points, ids, box_id)
        assert mask.sum() >= 30, f"scene object {box_id} barely visible"
        labels = result.labels[mask]
        # A few grazing-angle returns on a top edge may be legitimate DBSCAN noise.
        assert np.mean(labels >= 0) >= 0.98, f"object {box_id} largely unclustered"
        clusters = np.unique(labels[labels >= 0])
        assert clusters.size == 1, f"object {box_id} split into {clusters}"
        found.append(int(clusters[0]))
    assert len(set(found)) == len(scene.boxes), "two objects merged into one cluster"
    assert result.num_clusters == len(scene.boxes)


def test_noise_water_and_terrain_stay_unlabelled(scan):
    scene, points, ids = scan
    result = process_scan(points, LidarConfig())
    assert np.all(result.labels[ids == NOISE] == -1)
    background = (ids == WATER) | (ids == BANK)
    assert np.all(result.labels[background] == -1)
    assert not result.obstacle[background].any(), "water or terrain survived the removal"
    assert result.water_level_z_m == pytest.approx(scene.water_z_m, abs=0.05)


def test_boxes_are_small_and_cover_every_clustered_point(scan):
    _, points, _ = scan
    result = process_scan(points, LidarConfig())
    boxes = result.boxes
    assert len(boxes) > result.num_clusters, "the 12 m barge must have been subdivided"
    assert np.all(boxes.size_xyz < 3.0)
    assert np.all(boxes.num_points > 0)
    clustered = np.flatnonzero(result.labels >= 0)
    xyz = points[clustered, :3]
    inside = (
        (xyz[:, None, :] >= boxes.min_xyz[None]) & (xyz[:, None, :] <= boxes.max_xyz[None])
    ).all(axis=2)
    same_cluster = result.labels[clustered][:, None] == boxes.cluster_id[None, :]
    assert np.all((inside & same_cluster).any(axis=1)), "a clustered point lies in no box"
    assert boxes.num_points.sum() == clustered.size


def test_ground_removal_keeps_objects_on_a_slope():
    """An object on the bank (the shed, box 7) survives; the bank under it does not."""
    scene = default_scene()
    points, ids = raycast(scene, lidar_directions(0.5, 0.5))
    keep, water_z = obstacle_points(points, LidarConfig())
    shed = clear_object_points(scene, points, ids, 7)
    assert keep[shed].all()
    assert not keep[ids == BANK].any()
    assert water_z == pytest.approx(scene.water_z_m, abs=0.05)


def test_ground_removal_ignores_a_single_low_outlier_per_cell():
    scene = default_scene()
    points, ids = raycast(scene, lidar_directions(0.5, 0.5))
    shed = clear_object_points(scene, points, ids, 7)
    below = np.array([[-18.0, 47.0, scene.bank_z_m(np.array([47.0]))[0] - 3.0, 0.2]], np.float32)
    keep, _ = obstacle_points(np.vstack([points, below]), LidarConfig())
    assert keep[:-1][shed].all()


def test_configured_water_level_is_used():
    """A crowded plane at -3 m would be estimated as the water; the configured -1.8 m wins."""
    gx, gy = np.meshgrid(np.arange(5.0, 25.0, 0.25), np.arange(-10.0, 10.0, 0.25))
    floor = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, -3.0), np.zeros(gx.size)])
    probes = np.array([[15, 0, -1.6, 0], [15, 0.1, -1.4, 0]])
    points = np.vstack([floor, probes]).astype(np.float32)
    estimated_keep, estimated_z = obstacle_points(points, LidarConfig())
    assert estimated_z == pytest.approx(-3.0)
    assert estimated_keep[-2:].tolist() == [True, True]
    config = LidarConfig(ground=GroundConfig(water_level_z_m=-1.8))
    keep, water_z = obstacle_points(points, config)
    assert water_z == -1.8
    assert keep[-2:].tolist() == [False, True]
    assert not keep[:-2].any()


def test_water_level_estimate_picks_the_crowded_plane():
    rng = np.random.default_rng(1)
    water = np.full(5000, -3.0) + rng.normal(0, 0.01, 5000)
    bank = rng.uniform(-3.0, 4.0, 2000)
    assert estimate_water_level(np.concatenate([water, bank]), 0.1) == pytest.approx(-3, abs=0.05)
    assert estimate_water_level(np.array([1.0, 2.0]), 0.1) is None


def test_range_crop_drops_nan_near_and_far_returns():
    points = np.array(
        [[np.nan, 0, 0, 0], [0.5, 0, 0, 0], [50, 0, 0, 0], [0, 120, 0, 0], [3, 4, np.inf, 0]],
        np.float32,
    )
    assert range_mask(points, 1.5, 100.0).tolist() == [False, False, True, False, False]


def test_voxels_map_back_and_weight_by_count():
    xyz = np.array([[0.01, 0.01, 0.01], [0.05, 0.02, 0.03], [1.0, 1.0, 1.0]], np.float32)
    voxels = voxel_downsample(xyz, 0.2)
    assert voxels.centroids.shape == (2, 3)
    assert sorted(voxels.counts.tolist()) == [1, 2]
    np.testing.assert_allclose(voxels.centroids[voxels.inverse[0]], [0.03, 0.015, 0.02], atol=1e-6)
    assert voxels.inverse[0] == voxels.inverse[1] != voxels.inverse[2]


@pytest.mark.parametrize("method", ["kmeans", "birch"])
def test_alternative_methods_produce_boxes(scan, method):
    _, points, _ = scan
    result = process_scan(points, LidarConfig(method=method, n_clusters=8))
    if method == "kmeans":
        assert result.num_clusters == 8
    else:  # BIRCH micro-clusters merged within eps: at least one cluster per object
        assert result.num_clusters >= 8
    kept = result.obstacle
    assert np.all(result.labels[kept] >= 0), f"{method} labels every kept point"
    assert np.all(result.boxes.size_xyz < 3.0)


def test_pipeline_accepts_a_pointcloud2_view(scan, check_canonical):
    _, points, _ = scan
    msg = pack_points(points, 1_500_000_000, "lidar")
    check_canonical("sensor_msgs/msg/PointCloud2", msg)
    view = view_points(msg)
    assert np.shares_memory(view, np.frombuffer(msg["data"], np.uint8))
    np.testing.assert_array_equal(view, points)
    assert process_scan(view, LidarConfig()).num_clusters == 8


def test_box_messages_are_canonical(scan, check_canonical):
    _, points, _ = scan
    result = process_scan(points, LidarConfig())
    boxes_msg = box_array_msg(result.boxes, 2_000_000_001, "lidar", "dbscan", result.num_clusters)
    check_canonical("riverbridge_msgs/msg/BoxArray", boxes_msg)
    assert len(boxes_msg["boxes"]) == len(result.boxes)
    assert boxes_msg["header"]["stamp"] == {"sec": 2, "nanosec": 1}
    markers = marker_array_msg(result.boxes, 2_000_000_001, "lidar")
    check_canonical("visualization_msgs/msg/MarkerArray", markers)
    assert markers["markers"][0]["action"] == 3  # DELETEALL first: stale boxes vanish
    cubes = markers["markers"][1:]
    assert len(cubes) == len(result.boxes)
    assert {m["type"] for m in cubes} == {1} and {m["action"] for m in cubes} == {0}
    assert len({m["id"] for m in cubes}) == len(cubes)
    first = cubes[0]
    np.testing.assert_allclose(
        [first["pose"]["position"][a] for a in "xyz"], result.boxes.center_xyz[0], rtol=1e-6
    )


def test_empty_scan_gives_no_boxes(check_canonical):
    result = process_scan(np.empty((0, 4), np.float32), LidarConfig())
    assert len(result.boxes) == 0 and result.num_clusters == 0
    check_canonical(
        "visualization_msgs/msg/MarkerArray", marker_array_msg(result.boxes, 0, "lidar")
    )


def test_pipeline_returns_the_spans_of_its_steps(scan):
    _, points, _ = scan
    steps = process_scan(points, LidarConfig()).steps
    assert list(steps) == ["filter", "dbscan", "boxes"]
    (f0, f1), (d0, d1), (b0, b1) = steps.values()
    assert f0 <= f1 == d0 <= d1 == b0 <= b1  # back to back, in pipeline order
