"""Synthetic sensor data with known content, for the navigation tests and benchmark.

A river scene analytically ray-cast: a water plane, two sloped banks, axis-aligned boxes
(the obstacles) and optional isolated noise returns. Every return carries the id of the
surface it hit, so tests know the truth per point.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from navigation.messages import header_msg

WATER = -1  # surface ids below zero are background
BANK = -2
NOISE = -3


@dataclass(frozen=True)
class RiverScene:
    """Sensor at the origin, ``sensor_height_m`` above the water; banks rise beyond
    ``bank_start_m`` on both sides of y with ``bank_slope``; boxes as (lo, hi) corners."""

    sensor_height_m: float = 2.5
    bank_start_m: float = 35.0
    bank_slope: float = 0.25
    boxes: list[tuple[tuple[float, float, float], tuple[float, float, float]]] = field(
        default_factory=list
    )

    @property
    def water_z_m(self) -> float:
        return -self.sensor_height_m

    def bank_z_m(self, y_m: np.ndarray) -> np.ndarray:
        """Terrain height at lateral offset y: (n,) -> (n,)."""
        return self.water_z_m + self.bank_slope * np.maximum(np.abs(y_m) - self.bank_start_m, 0)


def default_scene() -> RiverScene:
    """Eight obstacles: buoys, boats, a long barge (needs subdivision), a pole, a shed on
    the bank. Bottoms sit below the water line as floating objects do."""
    w = -2.5
    return RiverScene(
        boxes=[
            ((12.0, 4.0, w - 0.5), (13.0, 5.0, w + 1.5)),  # buoy
            ((-15.0, -8.0, w - 0.5), (-13.0, -6.5, w + 2.0)),  # small boat
            ((25.0, -12.0, w - 1.0), (37.0, -8.0, w + 3.0)),  # barge, 12 m long
            ((-6.0, 18.0, w - 0.5), (-5.5, 18.5, w + 8.0)),  # pole, 8 m tall
            ((40.0, 15.0, w - 0.5), (45.0, 20.0, w + 2.5)),  # moored boat
            ((-35.0, 10.0, w - 0.5), (-31.0, 14.0, w + 4.0)),  # pontoon with cabin
            ((5.0, -25.0, w - 0.5), (7.0, -22.0, w + 1.0)),  # low boat
            ((-20.0, 45.0, w + 2.0), (-16.0, 49.0, w + 7.0)),  # shed on the bank
        ]
    )


def lidar_directions(h_res_deg: float, v_res_deg: float, v_fov_deg: float = 60.0) -> np.ndarray:
    """Unit ray directions of a spinning LIDAR: (n_az * n_el, 3) float64 (thesis table 4.3)."""
    az = np.deg2rad(np.arange(0.0, 360.0, h_res_deg))
    el = np.deg2rad(np.arange(-v_fov_deg / 2, v_fov_deg / 2, v_res_deg) + v_res_deg / 2)
    az_grid, el_grid = np.meshgrid(az, el, indexing="ij")
    cos_el = np.cos(el_grid)
    dirs = np.stack([cos_el * np.cos(az_grid), cos_el * np.sin(az_grid), np.sin(el_grid)], -1)
    return dirs.reshape(-1, 3)


def _plane_hits(scene: RiverScene, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest hit on water or bank: ray length (n,) (inf on a miss) and surface id (n,)."""
    dz = dirs[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_water = np.where(dz < 0, scene.water_z_m / dz, np.inf)
        y_water = t_water * dirs[:, 1]
        t_water = np.where(np.abs(y_water) <= scene.bank_start_m, t_water, np.inf)
        best_t, best_id = t_water, np.full(dirs.shape[0], WATER)
        for side in (1.0, -1.0):
            # Bank plane: z = water + slope * (side * y - start).
            denom = dz - scene.bank_slope * side * dirs[:, 1]
            numer = scene.water_z_m - scene.bank_slope * scene.bank_start_m
            t_bank = np.where(denom < 0, numer / denom, np.inf)
            on_side = side * t_bank * dirs[:, 1] > scene.bank_start_m
            t_bank = np.where(on_side & (t_bank > 0), t_bank, np.inf)
            closer = t_bank < best_t
            best_t = np.where(closer, t_bank, best_t)
            best_id = np.where(closer, BANK, best_id)
    return best_t, best_id


def raycast(scene: RiverScene, dirs: np.ndarray, max_range_m: float = 150.0) -> tuple:
    """Ray-cast the scene: points (n, 4) float32 with NaN on misses, surface id (n,) int.

    Box ids are 0.. in ``scene.boxes`` order; intensity is 1 for boxes, 0.2 otherwise.
    """
    best_t, best_id = _plane_hits(scene, dirs)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        for box_id, (lo, hi) in enumerate(scene.boxes):
            t1 = np.asarray(lo) * inv
            t2 = np.asarray(hi) * inv
            t_near = np.nanmax(np.minimum(t1, t2), axis=1)
            t_far = np.nanmin(np.maximum(t1, t2), axis=1)
            hit = (t_far >= t_near) & (t_near > 0) & (t_near < best_t)
            best_t = np.where(hit, t_near, best_t)
            best_id = np.where(hit, box_id, best_id)
    valid = best_t <= max_range_m
    xyz = dirs * np.where(valid, best_t, np.nan)[:, None]
    intensity = np.where(best_id >= 0, 1.0, 0.2)
    points = np.column_stack([xyz, intensity]).astype(np.float32)
    return points, np.where(valid, best_id, NOISE - 1)


def with_noise(
    scene: RiverScene, points: np.ndarray, ids: np.ndarray, count: int, seed: int = 0
) -> tuple:
    """Append ``count`` isolated returns scattered in the air, 2 to 15 m above the terrain
    (a ray cannot return from inside the ground)."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-80.0, 80.0, size=(count, 2))
    z = (scene.bank_z_m(xy[:, 1]) + rng.uniform(2.0, 15.0, size=count))[:, None]
    noise = np.column_stack([xy, z, np.full((count, 1), 0.1)]).astype(np.float32)
    return np.vstack([points, noise]), np.concatenate([ids, np.full(count, NOISE)])


def radar_noise_image(
    n_beams: int, n_cells: int, mean_power: float = 1.0, seed: int = 0
) -> np.ndarray:
    """Square-law detected Rayleigh clutter: exponential power, (beams, cells) float32."""
    rng = np.random.default_rng(seed)
    return rng.exponential(mean_power, size=(n_beams, n_cells)).astype(np.float32)


def radar_image_of(power: np.ndarray, stamp_ns: int, range_step_m: float) -> dict[str, Any]:
    """A RadarImage carrying `power` (beams x cells) with beams evenly over the full circle,
    5 deg wide by 15 deg high, from range 0."""
    beams, cells = power.shape
    return {
        "header": header_msg(stamp_ns, "radar"),
        "azimuth_min_rad": 0.0,
        "azimuth_step_rad": float(np.float32(2 * np.pi / beams)),
        "beam_width_azimuth_rad": float(np.float32(np.deg2rad(5.0))),
        "beam_width_elevation_rad": float(np.float32(np.deg2rad(15.0))),
        "range_min_m": 0.0,
        "range_step_m": range_step_m,
        "num_beams": beams,
        "num_cells": cells,
        "reflectance": power.reshape(-1),
    }


def radar_image_msg(
    stamp_ns: int, n_cells: int, range_step_m: float, target_cell: int
) -> dict[str, Any]:
    """A RadarImage of 72 beams of 5 deg: clutter (`radar_noise_image`, seed 1) with one strong
    return (power 500) at beam 18 (90 deg), cell `target_cell`."""
    power = radar_noise_image(72, n_cells, 1.0, seed=1)
    power[18, target_cell] = 500.0
    return radar_image_of(power, stamp_ns, range_step_m)


def camera_line_msg(stamp_ns: int, width_px: int, height_px: int) -> dict[str, Any]:
    """A CompressedImage (JPEG) of a dark frame crossed by one white horizontal line, 5/8 down."""
    image = np.full((height_px, width_px, 3), 30, np.uint8)
    row = height_px * 5 // 8
    cv2.line(image, (0, row), (width_px - 1, row), (255, 255, 255), 3)
    jpeg = cv2.imencode(".jpg", image)[1].tobytes()
    return {"header": header_msg(stamp_ns, "camera"), "format": "jpeg", "data": jpeg}


def imu_msg(stamp_ns: int) -> dict[str, Any]:
    """An Imu at rest and level, turning slowly (0.01 rad/s yaw)."""
    return {
        "header": header_msg(stamp_ns, "imu"),
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "orientation_covariance": [0.0] * 9,
        "angular_velocity": {"x": 0.0, "y": 0.0, "z": 0.01},
        "angular_velocity_covariance": [0.0] * 9,
        "linear_acceleration": {"x": 0.0, "y": 0.0, "z": 9.81},
        "linear_acceleration_covariance": [0.0] * 9,
    }
