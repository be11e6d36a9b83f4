"""Camera: pinhole geometry, shading of a known wall, sky, JPEG and the CompressedImage message."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from simulator.camera import Camera, pixel_directions
from simulator.config import CameraConfig, MountConfig
from simulator.frames import Pose2D
from tests.simulator.sim_scenes import WALL, box_scene

LEVEL = CameraConfig(mount=MountConfig(z_m=2.0, pitch_deg=0.0))


@pytest.fixture(scope="module")
def camera():
    sensor = Camera(LEVEL)
    yield sensor
    sensor.close()


def test_pixel_rays_follow_the_pinhole_model():
    cfg = CameraConfig(width_px=640, height_px=480, vertical_fov_deg=60.0)
    rays = pixel_directions(cfg).reshape(480, 640, 3)
    # Body frame: x forward, y left, z up. The centre pixels look forward.
    np.testing.assert_allclose(rays[239:241, 319:321].mean(axis=(0, 1)), [1, 0, 0], atol=1e-3)
    # Top row at +30 deg minus half a pixel, left column to the left (+y).
    top = np.degrees(np.arcsin(rays[0, 320, 2]))
    assert top == pytest.approx(30.0, abs=0.1)
    assert rays[240, 0, 1] > 0 > rays[240, 639, 1]


def test_wall_ahead_shows_its_colour_and_sky_above(camera):
    # A low wall ahead (top at 1 m, camera at 2 m) fills the lower half; sky above the horizon.
    scene = box_scene((30.0, -500.0, -30.0), (31.0, 500.0, 1.0))
    image = camera.render(scene, Pose2D(0.0, 0.0, 0.0))
    assert image.shape == (480, 640, 3) and image.dtype == np.uint8
    b, g, r = image[400, 320].astype(int)
    assert r > g and r > b  # the wall is red (RGB 200, 40, 30) in BGR order
    wall_direction = np.array([-1.0, 0.0, 0.0])  # face normal towards the camera
    sun = np.asarray(LEVEL.sun_direction_xyz) / np.linalg.norm(LEVEL.sun_direction_xyz)
    light = LEVEL.ambient + (1 - LEVEL.ambient) * max(0.0, float(wall_direction @ sun))
    haze = 1 - np.exp(-30.0 / 2500.0)
    expected_red = WALL.colour_rgb[0] * light * (1 - haze) + 200.0 * haze
    assert r == pytest.approx(expected_red, abs=2)
    sky_b, _, sky_r = image[10, 320].astype(int)
    assert sky_b > sky_r  # blue sky


def test_yaw_turns_the_view(camera):
    scene = box_scene((30.0, -500.0, -30.0), (31.0, 500.0, 1.0))
    ahead = camera.render(scene, Pose2D(0.0, 0.0, 0.0))
    behind = camera.render(scene, Pose2D(0.0, 0.0, np.pi))
    assert ahead[400, 320, 2] > ahead[400, 320, 0]  # red wall ahead
    # Facing away there is nothing below the horizon: the horizon colour of the sky (BGR).
    np.testing.assert_array_equal(behind[400, 320], [230, 215, 200])


def test_jpeg_message_decodes_to_the_frame(camera, small_scene, check_canonical):
    image = camera.render(small_scene, small_scene.start_pose)
    jpeg = camera.encode(image)
    decoded = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert decoded.shape == image.shape
    assert np.abs(decoded.astype(int) - image.astype(int)).mean() < 4.0
    msg = camera.message(jpeg, stamp_ns=42)
    assert msg["format"] == "jpeg" and msg["data"] == jpeg
    assert msg["header"] == {"stamp": {"sec": 0, "nanosec": 42}, "frame_id": "camera_optical"}
    check_canonical("sensor_msgs/msg/CompressedImage", msg)
