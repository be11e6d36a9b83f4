"""Detection quality: navigation's outputs judged against the simulator's ground truth.

Pure functions over canonical messages (no I/O), used by the report; docs/quality.md defines
the matching. A judge pairs, by stamp, a ``/sim/ground_truth/lidar`` message with the
``/nav/boxes`` of the same scan, and a ``/sim/ground_truth/radar`` message with the
``/nav/radar_detections`` of the same sweep; both sides are in the same sensor frame.

* LIDAR: an object is *visible* when at least ``LIDAR_MIN_RETURNS`` points of the scan lie on
  it and its centre is within ``EVALUATION_RANGE_M``. A box is *true* when its centre lies in
  some object's oriented box grown by ``MATCH_MARGIN_M``; an object is *detected* when a box
  centre lies in its grown box. precision = true boxes / boxes; recall = detected visible
  objects / visible objects, pooled over all scans.
* Radar: an object is *visible* when it gives most of the reflectance of at least one cell.
  A target is *true* when its strongest cell holds a real reflector (an object or land);
  false on open water (water returns only, or none). An object is *detected* when one of its
  dominant cells is a detected cell. The open-water false-alarm rate is detected cells among
  open-water cells, to set beside the configured P_fa.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from clients.report.results import LidarCounts, LidarQuality, RadarCounts, RadarQuality

LIDAR_MIN_RETURNS = 10  # thesis table 4.4 MinPts: fewer returns cannot make a cluster
EVALUATION_RANGE_M = 100.0  # thesis 4.1: obstacles of interest within about 100 m
MATCH_MARGIN_M = 1.0  # thesis table 4.4 Eps: a cluster reaches this far beyond its points
# GroundTruthArray.cell_source values that are no object (docs/quality.md)
LAND, WATER, NO_RETURN = -1, -2, -3

Msg = Mapping[str, Any]


def _xyz(point: Msg) -> list[float]:
    return [float(point["x"]), float(point["y"]), float(point["z"])]


def inside_objects(centres: np.ndarray, objects: list[Msg], margin_m: float) -> np.ndarray:
    """Which centres (m, 3) lie in which objects' oriented boxes grown by ``margin_m``:
    (m, k) bool. Boxes turn about z by their ``yaw_rad``."""
    if not objects or len(centres) == 0:
        return np.zeros((len(centres), len(objects)), bool)
    centre = np.array([_xyz(o["center"]) for o in objects])
    half = np.array([_xyz(o["size"]) for o in objects]) / 2 + margin_m
    yaw = np.array([float(o["yaw_rad"]) for o in objects])
    d = np.asarray(centres, np.float64)[:, None, :] - centre[None]
    c, s = np.cos(yaw)[None], np.sin(yaw)[None]
    along = c * d[..., 0] + s * d[..., 1]
    across = -s * d[..., 0] + c * d[..., 1]
    inside: np.ndarray = (
        (np.abs(along) <= half[None, :, 0])
        & (np.abs(across) <= half[None, :, 1])
        & (np.abs(d[..., 2]) <= half[None, :, 2])
    )
    return inside


def lidar_scan_counts(truth: Msg, boxes: Msg) -> LidarCounts:
    """One scan: boxes, true boxes, visible objects, detected visible objects."""
    objects = list(truth["objects"])
    items = list(boxes["boxes"])
    centres = np.array(
        [
            [(a + b) / 2 for a, b in zip(_xyz(box["min"]), _xyz(box["max"]), strict=True)]
            for box in items
        ]
    )
    inside = inside_objects(centres.reshape(-1, 3), objects, MATCH_MARGIN_M)
    visible = np.array(
        [
            int(o["returns"]) >= LIDAR_MIN_RETURNS and float(o["range_m"]) <= EVALUATION_RANGE_M
            for o in objects
        ],
        bool,
    )
    detected = inside.any(axis=0) & visible
    return LidarCounts(
        boxes=len(items),
        true_boxes=int(inside.any(axis=1).sum()),
        visible_objects=int(visible.sum()),
        detected_objects=int(detected.sum()),
    )


def radar_sweep_counts(truth: Msg, detections: Msg) -> RadarCounts:
    """One sweep: targets by what their strongest cell holds, objects, open-water cells."""
    source = np.asarray(truth["cell_source"], np.int64).reshape(
        int(truth["num_beams"]), int(truth["num_cells"])
    )
    cells = [(int(d["beam"]), int(d["cell"])) for d in detections["detections"]]
    hit = np.zeros(source.shape, bool)
    if cells:
        hit[tuple(np.array(cells).T)] = True
    peak = np.array(
        [source[int(t["peak_beam"]), int(t["peak_cell"])] for t in detections["targets"]], np.int64
    )
    visible = {int(o["id"]) for o in truth["objects"] if int(o["dominant_cells"]) > 0}
    detected = set(np.unique(source[hit & (source >= 0)]).tolist()) & visible
    open_water = (source == WATER) | (source == NO_RETURN)
    return RadarCounts(
        targets=len(peak),
        on_object=int((peak >= 0).sum()),
        on_land=int((peak == LAND).sum()),
        on_open_water=int(((peak == WATER) | (peak == NO_RETURN)).sum()),
        visible_objects=len(visible),
        detected_objects=len(detected),
        open_water_cells=int(open_water.sum()),
        open_water_detections=int((hit & open_water).sum()),
    )


def _ratio(num: int, den: int) -> float:
    return num / den if den else math.nan


def lidar_quality(pairs: Iterable[tuple[Msg, Msg]]) -> LidarQuality:
    """Precision and recall of the LIDAR boxes over (truth, boxes) pairs of the same scan."""
    counts = [lidar_scan_counts(truth, boxes) for truth, boxes in pairs]
    total = sum(counts, LidarCounts())
    return LidarQuality(
        scans=len(counts),
        counts=total,
        precision=_ratio(total.true_boxes, total.boxes),
        recall=_ratio(total.detected_objects, total.visible_objects),
        min_returns=LIDAR_MIN_RETURNS,
        range_m=EVALUATION_RANGE_M,
        margin_m=MATCH_MARGIN_M,
    )


def radar_quality(pairs: Iterable[tuple[Msg, Msg]]) -> RadarQuality:
    """Precision, recall and the open-water false-alarm rate of the radar targets over
    (truth, detections) pairs of the same sweep."""
    configured = math.nan
    counts = []
    for truth, detections in pairs:
        configured = float(detections["false_alarm_rate"])
        counts.append(radar_sweep_counts(truth, detections))
    total = sum(counts, RadarCounts())
    return RadarQuality(
        sweeps=len(counts),
        counts=total,
        precision=_ratio(total.on_object + total.on_land, total.targets),
        recall=_ratio(total.detected_objects, total.visible_objects),
        open_water_false_alarm_rate=_ratio(total.open_water_detections, total.open_water_cells),
        configured_false_alarm_rate=configured,
    )


def pair_by_stamp(truths: Iterable[Msg], outputs: Iterable[Msg]) -> list[tuple[Msg, Msg]]:
    """(truth, output) pairs whose header stamps are equal, in stamp order."""

    def key(msg: Msg) -> tuple[int, int]:
        stamp = msg["header"]["stamp"]
        return int(stamp["sec"]), int(stamp["nanosec"])

    by_stamp = {key(m): m for m in truths}
    return sorted(
        ((by_stamp[key(m)], m) for m in outputs if key(m) in by_stamp),
        key=lambda pair: key(pair[0]),
    )
