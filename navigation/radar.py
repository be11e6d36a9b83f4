"""Radar polar image -> CFAR detections -> Cartesian -> ``RadarDetectionArray``.

The image is ``riverbridge_msgs/msg/RadarImage``: one row per azimuth beam, one column per
range cell (thesis 3.5.2). Detections are converted to Cartesian sensor coordinates as the
thesis does before publishing (3.5.3), one per detected cell at the cell centre.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from navigation.cfar import CfarDetector
from navigation.messages import f32, header_msg


@dataclass(frozen=True)
class PolarGeometry:
    """Where beams and cells lie: beam i points at azimuth_min_rad + i * azimuth_step_rad
    (counter-clockwise from the sensor x axis); cell j spans range_min_m + j * range_step_m
    to one step further."""

    azimuth_min_rad: float
    azimuth_step_rad: float
    range_min_m: float
    range_step_m: float

    @classmethod
    def of(cls, msg: dict[str, Any]) -> PolarGeometry:
        return cls(
            float(msg["azimuth_min_rad"]),
            float(msg["azimuth_step_rad"]),
            float(msg["range_min_m"]),
            float(msg["range_step_m"]),
        )


def radar_power(msg: dict[str, Any]) -> np.ndarray:
    """The reflectance of a canonical RadarImage as (beams, cells) float32, no copy."""
    beams, cells = int(msg["num_beams"]), int(msg["num_cells"])
    reflectance = np.asarray(msg["reflectance"], dtype=np.float32)
    if reflectance.size != beams * cells:
        raise ValueError(f"reflectance has {reflectance.size} values, need {beams}x{cells}")
    return reflectance.reshape(beams, cells)


@dataclass(frozen=True)
class RadarDetections:
    """Detected cells, all (k,) float32: polar position, Cartesian position in the sensor
    frame, cell power and the threshold it exceeded."""

    range_m: np.ndarray
    azimuth_rad: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    power: np.ndarray
    threshold: np.ndarray

    def __len__(self) -> int:
        return int(self.range_m.shape[0])


def detect(power: np.ndarray, geometry: PolarGeometry, detector: CfarDetector) -> RadarDetections:
    """CFAR on every beam, detections at their cell centres: (beams, cells) -> detections."""
    hits, threshold = detector.detect(power)
    beam, cell = np.nonzero(hits)
    range_m = geometry.range_min_m + (cell + 0.5) * geometry.range_step_m
    azimuth_rad = geometry.azimuth_min_rad + beam * geometry.azimuth_step_rad
    f32 = np.float32
    return RadarDetections(
        range_m.astype(f32),
        azimuth_rad.astype(f32),
        (range_m * np.cos(azimuth_rad)).astype(f32),
        (range_m * np.sin(azimuth_rad)).astype(f32),
        power[beam, cell].astype(f32),
        threshold[beam, cell].astype(f32),
    )


def detection_array_msg(
    detections: RadarDetections, stamp_ns: int, frame_id: str, detector: CfarDetector
) -> dict[str, Any]:
    """Canonical ``riverbridge_msgs/msg/RadarDetectionArray``."""
    columns = zip(
        detections.range_m.tolist(),
        detections.azimuth_rad.tolist(),
        detections.x_m.tolist(),
        detections.y_m.tolist(),
        detections.power.tolist(),
        detections.threshold.tolist(),
        strict=True,
    )
    names = ("range_m", "azimuth_rad", "x_m", "y_m", "power", "threshold")
    return {
        "header": header_msg(stamp_ns, frame_id),
        "detector": detector.kind,
        "false_alarm_rate": f32(detector.false_alarm_rate),
        "detections": [dict(zip(names, row, strict=True)) for row in columns],
    }
