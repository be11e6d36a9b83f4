"""Detection quality: navigation's outputs judged against the simulator's ground truth.

Pure functions over canonical messages (no I/O), used by the report; docs/quality.md defines
the matching. A judge pairs, by stamp, a ``/sim/ground_truth/lidar`` message with the
``/nav/boxes`` of the same scan, and a ``/sim/ground_truth/radar`` message with the
``/nav/radar_detections`` of the same sweep; both sides are in the same sensor frame.

Every figure is split in two classes: ``on_water``, the objects in the river (vessels, buoys,
pontoons: what a vessel must avoid) and ``bank``, those on the shore (trees, houses). Each
detection falls in exactly one class by what it lies on; bare land is never a true positive.

* LIDAR: a box is *on* an object when its centre lies in the object's oriented box grown by
  ``MATCH_MARGIN_M`` and the object has at least ``LIDAR_MIN_RETURNS`` points in the scan
  (fewer cannot form a cluster, so a box there was made of something else). A box on no such
  object is false: on_water when its bottom is within ``WATER_BAND_M`` of the water surface
  (an obstacle where a vessel sails), bank otherwise. An object is *visible* when it has
  ``LIDAR_MIN_RETURNS`` points and its centre is within ``EVALUATION_RANGE_M``; *detected*
  when a box is on it.
* Radar: a target is judged by its strongest cell: on an on-water or a bank object (true for
  that class), on bare land (a false bank target) or on open water, water returns only or
  none (a false on-water target). An object is *visible* when it gives most of the
  reflectance of at least one cell, *detected* when one of those cells is a detected cell.
  The open-water false-alarm rate is detected cells among open-water cells, beside P_fa.

precision = true detections / detections of the class; recall = detected visible objects /
visible objects of the class, pooled over all scans. ``shortfalls`` holds them to the targets.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from clients.report.results import (
    ClassCounts,
    ClassQuality,
    LidarCounts,
    LidarQuality,
    RadarCounts,
    RadarQuality,
)

LIDAR_MIN_RETURNS = 10  # thesis table 4.4 MinPts: fewer returns cannot make a cluster
EVALUATION_RANGE_M = 100.0  # thesis 4.1: obstacles of interest within about 100 m
MATCH_MARGIN_M = 1.0  # thesis table 4.4 Eps: a cluster reaches this far beyond its points
# A false LIDAR box whose bottom is this close to the water stands where a vessel sails; the
# banks rise 2 m over their first 15 m (simulator.valley), so bank clutter sits higher.
WATER_BAND_M = 0.5
# The targets for the on-water class: precision and recall at least these.
TARGET_PRECISION = 0.9
TARGET_RECALL = 0.8
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


def _class_counts(
    on_class: np.ndarray, false_here: np.ndarray, visible: np.ndarray, found: np.ndarray
) -> ClassCounts:
    """on_class (m,) detections on an object of the class; false_here (m,) false detections
    placed in the class; visible (k,) and found (k,) objects of the class."""
    return ClassCounts(
        detections=int(on_class.sum() + false_here.sum()),
        true_detections=int(on_class.sum()),
        objects=int(visible.sum()),
        detected_objects=int((visible & found).sum()),
    )


def lidar_scan_counts(truth: Msg, boxes: Msg) -> LidarCounts:
    """One scan: boxes, and per class the boxes, true boxes, visible and detected objects."""
    objects = list(truth["objects"])
    items = list(boxes["boxes"])
    lo = np.array([_xyz(box["min"]) for box in items]).reshape(-1, 3)
    hi = np.array([_xyz(box["max"]) for box in items]).reshape(-1, 3)
    returns = np.array([int(o["returns"]) for o in objects], np.int64)
    enough = returns >= LIDAR_MIN_RETURNS
    inside = inside_objects((lo + hi) / 2, objects, MATCH_MARGIN_M) & enough[None]
    water = np.array([bool(o["on_water"]) for o in objects], bool)
    in_range = np.array([float(o["range_m"]) <= EVALUATION_RANGE_M for o in objects], bool)
    visible = enough & in_range
    found = np.asarray(inside.any(axis=0), bool)
    on_water_box = (inside & water[None]).any(axis=1)
    on_bank_box = (inside & ~water[None]).any(axis=1) & ~on_water_box
    false_box = ~inside.any(axis=1)
    near_water = lo[:, 2] <= float(truth["water_z_m"]) + WATER_BAND_M
    return LidarCounts(
        boxes=len(items),
        on_water=_class_counts(on_water_box, false_box & near_water, visible & water, found),
        bank=_class_counts(on_bank_box, false_box & ~near_water, visible & ~water, found),
    )


def radar_sweep_counts(truth: Msg, detections: Msg) -> RadarCounts:
    """One sweep: targets by what their strongest cell holds, per class, open-water cells."""
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
    objects = list(truth["objects"])
    ids = np.array([int(o["id"]) for o in objects], np.int64)
    water = np.array([bool(o["on_water"]) for o in objects], bool)
    visible = np.array([int(o["dominant_cells"]) > 0 for o in objects], bool)
    found = np.isin(ids, source[hit & (source >= 0)])
    on_water_ids, bank_ids = ids[water], ids[~water]
    open_water_peak = (peak == WATER) | (peak == NO_RETURN)
    open_water = (source == WATER) | (source == NO_RETURN)
    return RadarCounts(
        targets=len(peak),
        on_water=_class_counts(
            np.isin(peak, on_water_ids), open_water_peak, visible & water, found
        ),
        bank=_class_counts(np.isin(peak, bank_ids), peak == LAND, visible & ~water, found),
        on_land=int((peak == LAND).sum()),
        on_open_water=int(open_water_peak.sum()),
        open_water_cells=int(open_water.sum()),
        open_water_detections=int((hit & open_water).sum()),
    )


def _ratio(num: int, den: int) -> float:
    return num / den if den else math.nan


def lidar_quality(pairs: Iterable[tuple[Msg, Msg]]) -> LidarQuality:
    """Per-class precision and recall of the LIDAR boxes over (truth, boxes) pairs of the
    same scan."""
    counts = [lidar_scan_counts(truth, boxes) for truth, boxes in pairs]
    total = sum(counts, LidarCounts())
    return LidarQuality(
        scans=len(counts),
        boxes=total.boxes,
        on_water=ClassQuality.of(total.on_water),
        bank=ClassQuality.of(total.bank),
        min_returns=LIDAR_MIN_RETURNS,
        range_m=EVALUATION_RANGE_M,
        margin_m=MATCH_MARGIN_M,
        water_band_m=WATER_BAND_M,
    )


def radar_quality(pairs: Iterable[tuple[Msg, Msg]]) -> RadarQuality:
    """Per-class precision and recall and the open-water false-alarm rate of the radar
    targets over (truth, detections) pairs of the same sweep."""
    configured = math.nan
    counts = []
    for truth, detections in pairs:
        configured = float(detections["false_alarm_rate"])
        counts.append(radar_sweep_counts(truth, detections))
    total = sum(counts, RadarCounts())
    return RadarQuality(
        sweeps=len(counts),
        targets=total.targets,
        on_water=ClassQuality.of(total.on_water),
        bank=ClassQuality.of(total.bank),
        on_land=total.on_land,
        on_open_water=total.on_open_water,
        open_water_cells=total.open_water_cells,
        open_water_detections=total.open_water_detections,
        open_water_false_alarm_rate=_ratio(total.open_water_detections, total.open_water_cells),
        configured_false_alarm_rate=configured,
    )


def shortfalls(quality: LidarQuality | RadarQuality) -> list[str]:
    """What keeps a sensor's on-water figures from the targets (empty: met). NaN (no
    detections, or no visible obstacle on the water) never meets one."""
    on_water = quality.on_water
    missed = []
    if not on_water.precision >= TARGET_PRECISION:
        missed.append(f"on_water precision {on_water.precision:.3f} < {TARGET_PRECISION}")
    if not on_water.recall >= TARGET_RECALL:
        missed.append(f"on_water recall {on_water.recall:.3f} < {TARGET_RECALL}")
    if isinstance(quality, RadarQuality) and not (
        quality.open_water_false_alarm_rate <= quality.configured_false_alarm_rate
    ):
        missed.append(
            f"open-water false alarms {quality.open_water_false_alarm_rate:.4f} > "
            f"P_fa {quality.configured_false_alarm_rate:g}"
        )
    return missed


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
