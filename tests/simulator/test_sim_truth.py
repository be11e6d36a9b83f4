"""Ground truth: the scene's objects, what each ray hit, the water models, the payload profile."""

from __future__ import annotations

import numpy as np
import pytest

from simulator import materials
from simulator.config import LidarConfig, MountConfig, RadarConfig, SimConfig
from simulator.frames import Pose2D, rotation_y
from simulator.lidar import Lidar
from simulator.objects import LAND, NO_RETURN, WATER, SceneObjects, object_boxes
from simulator.props import MeshPart
from simulator.radar import Radar
from simulator.scene import Scene, build_scene
from simulator.truth import TRUTH_TYPE, lidar_truth, markers_msg, radar_truth
from tests.simulator.sim_scenes import WALL, box_part

POST_ID = 0


def water_plane(material=materials.WATER) -> MeshPart:
    part = box_part((-500.0, -500.0, -1.0), (500.0, 500.0, 0.0), material)
    return MeshPart(part.vertices, part.faces, part.material, WATER)


def post_scene(x_m: float = 30.0) -> Scene:
    """A 2 m x 4 m x 10 m post (object 0) standing in water, east of the origin (4 m wide:
    both rays of a 5 deg radar beam, +-1.25 deg, hit it out to 90 m)."""
    post = box_part((x_m - 1.0, -2.0, -1.0), (x_m + 1.0, 2.0, 9.0))
    objects = object_boxes(
        "post",
        post.vertices,
        np.zeros(len(post.vertices), int),
        np.array([[x_m, 0.0, 0.0]]),
        np.zeros(1),
        first_id=POST_ID,
    )
    tagged = MeshPart(post.vertices, post.faces, post.material, np.zeros(len(post.faces), int))
    return Scene([tagged, water_plane()], water_level_m=0.0, objects=objects)


def test_every_prop_of_the_thesis_scene_is_an_object_with_a_box():
    scene = build_scene()
    objects = scene.objects
    kinds, counts = np.unique(objects.kinds.astype(str), return_counts=True)
    assert dict(zip(kinds, counts, strict=True)) == {  # thesis 3.5.1 and SceneConfig
        "buoy": 2,  # water obstacles 0 and 2
        "house": 30,
        "landing_stage": 5,
        "tree": 160,
        "vessel": 4,  # two moored, water obstacles 1 and 3 at anchor
    }
    on_water = {str(k) for k in np.unique(objects.kinds[objects.on_water])}
    assert on_water == {"buoy", "landing_stage", "vessel"}
    assert set(np.unique(objects.kinds[~objects.on_water]).astype(str)) == {"house", "tree"}
    np.testing.assert_array_equal(objects.ids, np.arange(len(objects)))
    tagged = np.unique(scene.face_source[scene.face_source >= 0])
    np.testing.assert_array_equal(tagged, objects.ids)
    assert set(np.unique(scene.face_source[scene.face_source < 0])) == {LAND, WATER}
    vessel = np.flatnonzero(objects.kinds == "vessel")[0]
    # an 8 m x 2.6 m hull from 0.6 m below the water, a cabin up to 2.5 m above it
    np.testing.assert_allclose(objects.size_xyz[vessel], [8.0, 2.6, 3.1], atol=1e-6)


def test_object_boxes_follow_the_instance_yaw():
    corners = np.array([[-2.0, -1.0, 0.0], [2.0, 1.0, 3.0]])
    yaw = np.pi / 2  # turned: its 4 m side now runs along map y
    rotated = corners @ np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    boxes = object_boxes(
        "box",
        rotated + np.array([10.0, 5.0, 0.0]),
        np.zeros(2, int),
        np.array([[10.0, 5.0, 0.0]]),
        np.array([yaw]),
        first_id=3,
    )
    np.testing.assert_allclose(boxes.size_xyz[0], [4.0, 2.0, 3.0], atol=1e-9)
    np.testing.assert_allclose(boxes.centre_xyz[0], [10.0, 5.0, 1.5], atol=1e-9)
    assert boxes.ids[0] == 3
    centres, yaws = boxes.in_sensor_frame(np.array([10.0, 0.0, 0.0]), np.eye(3), 0.5)
    np.testing.assert_allclose(centres[0], [0.0, 5.0, 1.5], atol=1e-9)
    assert yaws[0] == pytest.approx(yaw - 0.5)


def test_lidar_points_know_what_they_hit_and_the_truth_lists_the_object(check_canonical):
    scene = post_scene()
    lidar = Lidar(LidarConfig(range_max_m=60.0, mount=MountConfig(z_m=3.0)), threads=1)
    try:
        scan = lidar.scan_with_sources(scene, Pose2D(0.0, 0.0, 0.0))
    finally:
        lidar.close()
    on_post = scan.source == POST_ID
    assert on_post.sum() > 100 and set(np.unique(scan.source)) == {POST_ID, WATER}
    np.testing.assert_allclose(scan.points[on_post, 3], WALL.lidar_reflectivity)
    msg = lidar_truth(scene, lidar.cfg, Pose2D(0.0, 0.0, 0.0), scan.source, 5)
    check_canonical(TRUTH_TYPE, msg)
    (post,) = msg["objects"]
    assert (post["id"], post["kind"], post["returns"]) == (POST_ID, "post", int(on_post.sum()))
    # sensor 3 m above the water: the post's centre (4 m above the water) is 1 m above it
    assert (post["center"]["x"], post["center"]["y"], post["center"]["z"]) == pytest.approx(
        (30.0, 0.0, 1.0)
    )
    assert post["range_m"] == pytest.approx(30.0)
    assert msg["num_beams"] == 0 and len(msg["cell_source"]) == 0


def test_radar_cells_know_their_strongest_source(check_canonical):
    scene = post_scene(x_m=50.0)
    radar = Radar(RadarConfig(mount=MountConfig(z_m=3.0)))
    try:
        sweep = radar.sweep_with_sources(scene, Pose2D(0.0, 0.0, 0.0))
    finally:
        radar.close()
    source = sweep.cell_source
    assert source.shape == sweep.image.shape == (72, 25)
    assert source[0, 12] == POST_ID  # beam 0 looks east; 49 m falls in cell 12 (48-52 m)
    assert (source == POST_ID).sum() == 1
    assert (source == WATER).any() and (source == NO_RETURN).any()
    assert sweep.object_rays[POST_ID] > 0
    np.testing.assert_array_equal(sweep.image, radar.sweep(scene, Pose2D(0.0, 0.0, 0.0)))
    msg = radar_truth(scene, radar.cfg, Pose2D(0.0, 0.0, 0.0), sweep, 7)
    check_canonical(TRUTH_TYPE, msg)
    assert (msg["num_beams"], msg["num_cells"]) == (72, 25)
    assert msg["objects"][0]["dominant_cells"] == 1
    assert msg["cell_source"].reshape(72, 25)[0, 12] == POST_ID


@pytest.mark.parametrize(
    ("model", "pitch_deg", "returns"),
    [
        ("mesh", 0.0, True),  # the thesis's collision mesh: every ray on the water returns
        ("specular", 0.0, False),  # a level sensor meets the water at >= 60 deg: mirrored away
        ("specular", 80.0, True),  # looking almost straight down, the rays near nadir return
    ],
)
def test_water_models(model, pitch_deg, returns):
    scene = Scene([water_plane()], water_level_m=0.0)
    cfg = LidarConfig(
        water_model=model, range_max_m=30.0, mount=MountConfig(z_m=3.0, pitch_deg=pitch_deg)
    )
    lidar = Lidar(cfg, threads=1)
    try:
        scan = lidar.scan_with_sources(scene, Pose2D(0.0, 0.0, 0.0))
    finally:
        lidar.close()
    assert (len(scan.points) > 0) == returns
    assert (scan.source == WATER).all()
    if model == "specular" and returns:
        in_map = scan.points[:, :3] @ rotation_y(np.radians(pitch_deg)).T
        incidence_deg = np.degrees(np.arccos(np.abs(in_map[:, 2]) / np.linalg.norm(in_map, axis=1)))
        assert incidence_deg.max() <= cfg.water_max_incidence_deg + 0.01


def test_xyz_clouds_are_12_byte_points_navigation_reads(check_canonical):
    from schemas.pointcloud import XYZ, view_points

    points = np.arange(20, dtype=np.float32).reshape(5, 4)
    lidar = Lidar(LidarConfig(point_fields="xyz"), threads=1)
    try:
        msg = lidar.message(points, 9)
    finally:
        lidar.close()
    check_canonical("sensor_msgs/msg/PointCloud2", msg)
    assert msg["point_step"] == 12 and len(msg["data"]) == 60
    assert [f["name"] for f in msg["fields"]] == ["x", "y", "z"]
    np.testing.assert_array_equal(view_points(msg, XYZ), points[:, :3])


def test_the_thesis_profile_sets_its_payload_unless_the_file_says_otherwise():
    thesis = SimConfig(profile="thesis")
    assert (thesis.lidar.point_fields, thesis.lidar.water_model) == ("xyz", "specular")
    assert SimConfig().lidar.point_fields == "xyzi" and SimConfig().lidar.water_model == "mesh"
    mine = SimConfig.model_validate({"profile": "thesis", "lidar": {"water_model": "mesh"}})
    assert (mine.lidar.point_fields, mine.lidar.water_model) == ("xyz", "mesh")


def test_the_thesis_profile_sends_about_the_thesis_lidar_payload():
    """Table 4.9: 285.37 KB per LIDAR message (docs/quality.md); within 20 % here."""
    cfg = SimConfig(profile="thesis")
    scene = build_scene(cfg.scene, seed=cfg.seed)
    lidar = Lidar(cfg.lidar)
    try:
        msg = lidar.message(lidar.scan(scene, scene.start_pose), 0)
    finally:
        lidar.close()
    assert len(msg["data"]) == pytest.approx(285_370, rel=0.2)


def test_markers_show_every_object_in_the_map_frame(check_canonical):
    objects = SceneObjects(
        np.array([0, 1]),
        np.array(["tree", "house"], dtype=object),
        np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]),
        np.array([0.0, 1.0]),
        np.array([[1.0, 1.0, 5.0], [10.0, 8.0, 9.5]]),
        np.array([False, False]),
    )
    msg = markers_msg(objects, 11)
    check_canonical("visualization_msgs/msg/MarkerArray", msg)
    assert [(m["ns"], m["id"], m["header"]["frame_id"]) for m in msg["markers"]] == [
        ("tree", 0, "map"),
        ("house", 1, "map"),
    ]
    assert msg["markers"][1]["scale"] == {"x": 10.0, "y": 8.0, "z": 9.5}
