"""Procedural reproduction of the thesis scene (3.5.1): a river in a V-shaped valley.

The river runs south to north through the middle of the square and meanders gently; its cross
section is a parabolic bed below the water line, short banks, then valley sides rising at
`valley_slope`, roughened with seeded fractal noise away from the water.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from simulator.config import SceneConfig
from simulator.terrain import HeightField

BANK_WIDTH_M = 15.0  # strip between water line and valley side
BANK_HEIGHT_M = 2.0  # rise across that strip
NOISE_AMPLITUDE_M = 4.0  # relief of the valley sides; vanishes towards the river


@dataclass(frozen=True)
class RiverCourse:
    """River centre line x = centre_x_m(y): a sum of two sines (a meander) seeded per scene."""

    amplitudes_m: tuple[float, float]
    wavelengths_m: tuple[float, float]
    phases_rad: tuple[float, float]
    half_width_m: float
    water_level_m: float

    def _phase(self, y_m: np.ndarray | float) -> np.ndarray:
        """(..., 2) phase of each sine at the given y."""
        y: npt.NDArray[np.float64] = np.asarray(y_m, dtype=np.float64)[..., None]
        wavelengths_m = np.asarray(self.wavelengths_m, dtype=np.float64)
        return 2 * np.pi * y / wavelengths_m + np.asarray(self.phases_rad, dtype=np.float64)

    def centre_x_m(self, y_m: np.ndarray | float) -> np.ndarray:
        amplitudes_m = np.asarray(self.amplitudes_m, dtype=np.float64)
        x_m: npt.NDArray[np.float64] = (amplitudes_m * np.sin(self._phase(y_m))).sum(axis=-1)
        return x_m

    def heading_rad(self, y_m: np.ndarray | float) -> np.ndarray:
        """Direction of flow (towards +y) as a map yaw, counter-clockwise from +x."""
        gain = 2 * np.pi * np.asarray(self.amplitudes_m) / np.asarray(self.wavelengths_m)
        slope: npt.NDArray[np.float64] = (gain * np.cos(self._phase(y_m))).sum(axis=-1)
        return np.arctan2(1.0, slope)


def fractal_noise(rows: int, cols: int, rng: np.random.Generator, octaves: int = 5) -> np.ndarray:
    """Smooth noise in about [-1, 1]: coarse random grids upsampled bicubically and summed."""
    total = np.zeros((rows, cols), dtype=np.float32)
    amplitude, norm = 1.0, 0.0
    for octave in range(octaves):
        coarse = rng.standard_normal((4 * 2**octave + 1, 4 * 2**octave + 1)).astype(np.float32)
        total += amplitude * cv2.resize(coarse, (cols, rows), interpolation=cv2.INTER_CUBIC)
        norm += amplitude
        amplitude *= 0.5
    return total / norm


def valley_profile_m(distance_m: np.ndarray, cfg: SceneConfig) -> np.ndarray:
    """Height above the water line at a horizontal distance from the river centre line."""
    half = cfg.river_width_m / 2
    d = np.asarray(distance_m, dtype=np.float64)
    bed = -cfg.river_depth_m * (1.0 - np.minimum(d / half, 1.0) ** 2)
    bank = BANK_HEIGHT_M * np.clip((d - half) / BANK_WIDTH_M, 0.0, 1.0)
    side = cfg.valley_slope * np.maximum(d - half - BANK_WIDTH_M, 0.0)
    return np.where(d < half, bed, bank + side)


def generate_valley(cfg: SceneConfig, rng: np.random.Generator) -> tuple[HeightField, RiverCourse]:
    """The procedural terrain, `cfg.terrain_cells` cells per side, centred on the map origin."""
    water_level_m = 0.0 if cfg.water_level_m is None else cfg.water_level_m
    course = RiverCourse(
        amplitudes_m=(float(rng.uniform(60, 110)), float(rng.uniform(10, 30))),
        wavelengths_m=(float(rng.uniform(1800, 2600)), float(rng.uniform(500, 800))),
        phases_rad=(float(rng.uniform(0, 2 * np.pi)), float(rng.uniform(0, 2 * np.pi))),
        half_width_m=cfg.river_width_m / 2,
        water_level_m=water_level_m,
    )
    n = cfg.terrain_cells + 1
    spacing_m = cfg.size_m / cfg.terrain_cells
    coords = -cfg.size_m / 2 + np.arange(n) * spacing_m
    gx, gy = np.meshgrid(coords, coords)
    distance = np.abs(gx - course.centre_x_m(gy))
    # Roughness fades in over 60 m beyond the banks so the river and its shore stay clean.
    fade = np.clip((distance - course.half_width_m - BANK_WIDTH_M) / 60.0, 0.0, 1.0)
    relief = NOISE_AMPLITUDE_M * fade * fractal_noise(n, n, rng)
    heights = water_level_m + valley_profile_m(distance, cfg) + relief
    field = HeightField(heights.astype(np.float32), spacing_m, coords[0], coords[0])
    return field, course
