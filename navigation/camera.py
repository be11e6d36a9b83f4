"""Camera line extraction: JPEG -> grayscale -> Canny -> Hough (thesis 2.3, 3.5.3, table 4.6).

Lines are (k, 6) float32 rows [rho_px, theta_rad, x1, y1, x2, y2] in OpenCV's convention
(x right, y down, x cos(theta) + y sin(theta) = rho, theta in [0, pi)). Standard Hough lines
get their segment by clipping the infinite line to the image; probabilistic Hough segments
get the rho and theta of their supporting line.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
import numpy.typing as npt

from navigation.config import CameraConfig
from navigation.messages import header_msg

LINE_COLUMNS = ("rho_px", "theta_rad", "x1_px", "y1_px", "x2_px", "y2_px")


def decode_gray(jpeg: bytes | np.ndarray) -> np.ndarray:
    """Decode a compressed image straight to grayscale: -> (h, w) uint8."""
    image = cv2.imdecode(np.frombuffer(jpeg, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise ValueError("not a decodable image")
    return image


def edges(gray: np.ndarray, config: CameraConfig) -> np.ndarray:
    """Canny edge map with the thresholds of table 4.6: (h, w) uint8 -> (h, w) uint8."""
    return cv2.Canny(gray, config.canny_threshold1, config.canny_threshold2)


def hough_lines(edge_map: np.ndarray, config: CameraConfig) -> np.ndarray:
    """Lines of an edge map, standard or probabilistic Hough: -> (k, 6) float32."""
    theta_rad = np.deg2rad(config.theta_deg)
    height, width = edge_map.shape
    if config.probabilistic:
        found = cv2.HoughLinesP(
            edge_map,
            config.rho_px,
            theta_rad,
            config.threshold,
            minLineLength=config.min_line_length_px,
            maxLineGap=config.max_line_gap_px,
        )
        segments = np.empty((0, 4)) if found is None else found.reshape(-1, 4)
        return _with_polar(segments.astype(np.float64))
    found = cv2.HoughLines(edge_map, config.rho_px, theta_rad, config.threshold)
    polar = np.empty((0, 2)) if found is None else found.reshape(-1, 2).astype(np.float64)
    return clip_to_image(polar, width, height)


def clip_to_image(polar: np.ndarray, width: int, height: int) -> np.ndarray:
    """Segments where lines (k, 2) [rho, theta] cross the image rectangle: -> (k, 6) float32.

    Each line is intersected with the four borders x = 0, x = w-1, y = 0, y = h-1; of the
    crossings inside the rectangle the two extremes along the line are the endpoints. Lines
    that miss the image are dropped.
    """
    rho, theta = polar[:, 0], polar[:, 1]
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    x_max, y_max = width - 1.0, height - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = np.stack(
            [
                np.zeros_like(rho),
                np.full_like(rho, x_max),
                rho / cos_t,
                (rho - y_max * sin_t) / cos_t,
            ],
            axis=1,
        )
        ys = np.stack(
            [
                rho / sin_t,
                (rho - x_max * cos_t) / sin_t,
                np.zeros_like(rho),
                np.full_like(rho, y_max),
            ],
            axis=1,
        )
    eps = 1e-6
    inside = (xs >= -eps) & (xs <= x_max + eps) & (ys >= -eps) & (ys <= y_max + eps)
    inside &= np.isfinite(xs) & np.isfinite(ys)
    along = -sin_t[:, None] * xs + cos_t[:, None] * ys  # position along the line direction
    first = np.argmin(np.where(inside, along, np.inf), axis=1)
    last = np.argmax(np.where(inside, along, -np.inf), axis=1)
    rows = np.arange(rho.shape[0])
    keep: npt.NDArray[np.bool_] = inside.sum(axis=1) >= 1
    out: npt.NDArray[np.float64] = np.column_stack(
        [
            rho,
            theta,
            xs[rows, first],
            ys[rows, first],
            xs[rows, last],
            ys[rows, last],
        ]
    )
    return out[keep].astype(np.float32)


def _with_polar(segments: np.ndarray) -> np.ndarray:
    """Segments (k, 4) [x1, y1, x2, y2] -> (k, 6) with the supporting line's rho, theta."""
    x1, y1, x2, y2 = segments.T
    theta = np.mod(np.arctan2(x2 - x1, -(y2 - y1)), np.pi)  # normal of the direction
    rho = x1 * np.cos(theta) + y1 * np.sin(theta)
    return np.column_stack([rho, theta, segments]).astype(np.float32)


def extract_lines(jpeg: bytes | np.ndarray, config: CameraConfig) -> tuple[np.ndarray, int, int]:
    """The whole camera step: compressed image -> lines (k, 6) float32, width, height."""
    gray = decode_gray(jpeg)
    return hough_lines(edges(gray, config), config), gray.shape[1], gray.shape[0]


def line_array_msg(
    lines: np.ndarray, width: int, height: int, stamp_ns: int, frame_id: str, probabilistic: bool
) -> dict[str, Any]:
    """Canonical ``riverbridge_msgs/msg/ImageLineArray``."""
    return {
        "header": header_msg(stamp_ns, frame_id),
        "image_width": int(width),
        "image_height": int(height),
        "probabilistic": bool(probabilistic),
        "lines": [dict(zip(LINE_COLUMNS, row, strict=True)) for row in lines.tolist()],
    }
