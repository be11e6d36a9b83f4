"""Canny + Hough line extraction on drawn lines (thesis table 4.6)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from navigation.camera import clip_to_image, extract_lines, line_array_msg
from navigation.config import CameraConfig

WIDTH, HEIGHT = 640, 480


def jpeg_with_lines(segments: list[tuple[int, int, int, int]]) -> bytes:
    """A dark 640x480 frame with bright 3-px lines, JPEG-compressed as the camera sends it."""
    image = np.full((HEIGHT, WIDTH, 3), 30, np.uint8)
    for x1, y1, x2, y2 in segments:
        cv2.line(image, (x1, y1), (x2, y2), (255, 255, 255), 3)
    ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return encoded.tobytes()


def polar_of(x1, y1, x2, y2):
    theta = np.mod(np.arctan2(x2 - x1, -(y2 - y1)), np.pi)
    return x1 * np.cos(theta) + y1 * np.sin(theta), theta


SEGMENTS = [(0, 300, 639, 300), (200, 0, 200, 479), (0, 0, 479, 479)]  # horizon, post, diagonal


def assert_lines_found(lines: np.ndarray) -> None:
    for seg in SEGMENTS:
        rho, theta = polar_of(*seg)
        near = (np.abs(lines[:, 0] - rho) < 4.0) & (np.abs(lines[:, 1] - theta) < np.deg2rad(2))
        assert near.any(), f"line {seg} (rho {rho:.1f}, theta {np.rad2deg(theta):.1f}) missed"
    for rho, theta, x1, y1, x2, y2 in lines.tolist():
        # every endpoint lies on its own line
        for x, y in ((x1, y1), (x2, y2)):
            assert abs(x * np.cos(theta) + y * np.sin(theta) - rho) < 1.5


@pytest.mark.parametrize("probabilistic", [False, True])
def test_drawn_lines_are_found(probabilistic, check_canonical):
    config = CameraConfig(probabilistic=probabilistic)
    lines, width, height = extract_lines(jpeg_with_lines(SEGMENTS), config)
    assert (width, height) == (WIDTH, HEIGHT)
    assert_lines_found(lines)
    msg = line_array_msg(lines, width, height, 7, "camera", probabilistic)
    check_canonical("riverbridge_msgs/msg/ImageLineArray", msg)
    assert msg["probabilistic"] is probabilistic and len(msg["lines"]) == len(lines)


def test_blank_frame_has_no_lines():
    lines, _, _ = extract_lines(jpeg_with_lines([]), CameraConfig())
    assert lines.shape == (0, 6)


def test_standard_lines_are_clipped_to_the_image():
    polar = np.array([[300.0, np.pi / 2], [200.0, 0.0], [0.0, np.pi / 4], [2000.0, 0.3]])
    lines = clip_to_image(polar, WIDTH, HEIGHT)
    assert lines.shape == (3, 6)  # the last line misses the image
    horizon = sorted([tuple(lines[0, 2:4]), tuple(lines[0, 4:6])])
    np.testing.assert_allclose(horizon, [(0, 300), (639, 300)], atol=1e-3)
    post = sorted([tuple(lines[1, 2:4]), tuple(lines[1, 4:6])], key=lambda p: p[1])
    np.testing.assert_allclose(post, [(200, 0), (200, 479)], atol=1e-3)
    assert np.all(lines[:, [2, 4]] >= 0) and np.all(lines[:, [2, 4]] <= WIDTH - 1)
    assert np.all(lines[:, [3, 5]] >= 0) and np.all(lines[:, [3, 5]] <= HEIGHT - 1)


def test_undecodable_bytes_are_refused():
    with pytest.raises(ValueError, match="decodable"):
        extract_lines(b"not a jpeg", CameraConfig())
