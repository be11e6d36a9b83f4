"""The thesis's own figures, each with its statistic and source, beside ours (docs/report.md).

The thesis reports averages (Ø) of its methods in appendix A (table A.1), message sizes
averaged over 100 messages (table 4.9), the network load averaged over 300 s with nload
(table 4.10), and a few medians and maxima in the text of section 4.3 (figure 4.4). Every
row here names the thesis's statistic and source and computes *the same statistic* of ours
from a run; rows whose quantities differ in kind say so (``comparable`` False and a note).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from schemas.catalogue import TOPICS

LIDAR, RADAR, CAMERA, IMU = (TOPICS[key].name for key in ("lidar", "radar", "camera", "imu"))
PUBLISH_SIDE = ("generate", "publish_wait", "encode", "send")  # the simulator's share
STATISTICS = ("mean", "p50", "max", "max-p50", "ratio")

Run = Mapping[str, Any]
Extract = Callable[[Run], float | None]


@dataclass(frozen=True)
class ThesisFigure:
    """One figure of the thesis and how to compute ours the same way.

    relation : "=" for a measured value, "<" or ">" where the text gives a bound
    ("a median of below 10ms"), "~" where it gives an approximate value ("about 50ms").
    stage : the traced stage whose statistic ``ours`` takes, if it is one stage.
    """

    quantity: str
    topic: str
    statistic: str
    thesis: float
    unit: str
    source: str
    ours: Extract
    relation: str = "="
    comparable: bool = True
    note: str = ""
    stage: str = ""


def _of_stage(quantity: str, topic: str, stage: str, statistic: str, thesis: float,
              source: str, **details: Any) -> ThesisFigure:
    """A figure compared with one stage's ``statistic`` of ``topic`` (milliseconds)."""
    return ThesisFigure(quantity, topic, statistic, thesis, "ms", source,
                        stage_stat(topic, stage, statistic), stage=stage, **details)


def _stage(run: Run, topic: str, stage: str) -> Mapping[str, Any]:
    return run.get("topics", {}).get(topic, {}).get("stages", {}).get(stage, {})


def stage_stat(topic: str, stage: str, statistic: str) -> Extract:
    """``statistic`` (mean, p50, max, max-p50) of one stage of one topic."""
    def extract(run: Run) -> float | None:
        values = _stage(run, topic, stage)
        if not values.get("n"):
            return None
        if statistic == "max-p50":
            return float(values["max"]) - float(values["p50"])
        return float(values[statistic])
    return extract


def stage_mean_sum(topic: str, stages: Sequence[str]) -> Extract:
    """Sum of the stages' means: the mean of their sum (the mean is linear), as table A.1's
    "Sum" column adds the means of a class's methods."""
    def extract(run: Run) -> float | None:
        means = [_stage(run, topic, s).get("mean") for s in stages]
        return None if any(m is None for m in means) else float(sum(means))
    return extract


def payload_mean(topic: str) -> Extract:
    def extract(run: Run) -> float | None:
        value = run.get("topics", {}).get(topic, {}).get("payload_bytes_mean")
        return float(value) if value else None
    return extract


def network(key: str) -> Extract:
    def extract(run: Run) -> float | None:
        value = run.get("network", {}).get(key)
        return None if value is None or math.isnan(value) else float(value)
    return extract


_A1 = "table A.1"
_IMAGE_PATH = ("the thesis's image message carried an 88-byte file path; the JPEG went "
               "through the disk (3.5.3), ours carries the JPEG")
FIGURES: tuple[ThesisFigure, ...] = (
    # Transport Unity3d -> ROS2 (table A.1, 5a-5d: "the time that is needed for a
    # transmission from Unity3d to ROS"); ours: publisher ready -> subscriber decoded.
    _of_stage("transport", LIDAR, "transport", "mean", 86.0, f"{_A1} 5b",
              note="payload differs unless --profile thesis"),
    _of_stage("transport", RADAR, "transport", "mean", 30.0, f"{_A1} 5a"),
    _of_stage("transport", IMU, "transport", "mean", 9.0, f"{_A1} 5c"),
    _of_stage("transport", CAMERA, "transport", "mean", 6.0, f"{_A1} 5d", comparable=False,
              note=_IMAGE_PATH),
    _of_stage("transport", IMU, "transport", "p50", 10.0, "4.3, figure 4.4", relation="<",
              note='"a median of below 10ms"'),
    _of_stage("transport", IMU, "transport", "max", 80.0, "4.3, figure 4.4", relation=">",
              note='"transmission times of above 80ms are possible"'),
    _of_stage("transport", LIDAR, "transport", "max-p50", 50.0, "4.3, figure 4.4",
              relation="~", note='"the difference of the median to the highest latency value '
                                 '... about 50ms"'),
    # The Unity3d side per message (table A.1's "Sum" column of each sensor's methods):
    # ours is the simulator's share, capture -> handed to the socket.
    ThesisFigure("simulator per message", LIDAR, "mean", 69.0, "ms", f"{_A1} 1k, 2a, 2b (Sum)",
                 stage_mean_sum(LIDAR, PUBLISH_SIDE),
                 note="ray cast 10 ms (2a) + ROS# publish 59 ms (2b) in the thesis"),
    ThesisFigure("simulator per message", RADAR, "mean", 6.0, "ms", f"{_A1} 1a-1f (Sum)",
                 stage_mean_sum(RADAR, PUBLISH_SIDE)),
    ThesisFigure("simulator per message", CAMERA, "mean", 13.0, "ms", f"{_A1} 2c, 1g, 1h (Sum)",
                 stage_mean_sum(CAMERA, PUBLISH_SIDE),
                 note="Unity renders on a GPU; ours ray-casts on the CPU"),
    ThesisFigure("simulator per message", IMU, "mean", 0.0, "ms", f"{_A1} 1i, 1j (Sum)",
                 stage_mean_sum(IMU, PUBLISH_SIDE), note="below 0.5 ms, printed as 0"),
    # ROS2 processing (table A.1, 3a-3h without the matplotlib visualisation 4a-4d).
    _of_stage("scan -> boxes", LIDAR, "process", "mean", 218.0, f"{_A1} 3f + 3g + 3h",
              note="DBSCAN 29 + boxes 186 + publish 3; payload differs unless --profile thesis"),
    _of_stage("DBSCAN", LIDAR, "process.dbscan", "mean", 29.0, f"{_A1} 3f", comparable=False,
              note="the thesis clustered the whole cloud; ours the ~1k voxels left after the "
                   "water/terrain filter"),
    _of_stage("bounding boxes", LIDAR, "process.boxes", "mean", 186.0, f"{_A1} 3g",
              comparable=False,
              note="the thesis boxed clusters of the whole cloud; ours of the obstacle points"),
    _of_stage("CFAR -> detections", RADAR, "process", "mean", 2.0, f"{_A1} 3a + 3b",
              note="ours also groups the cells into targets"),
    _of_stage("image -> lines", CAMERA, "process", "mean", 17.0, f"{_A1} 3c + 3d + 3e",
              note="the thesis read the JPEG from disk (3c)"),
    # Message sizes (table 4.9, "Size Ø100": the average of 100 messages; KB read as 1000 B).
    ThesisFigure("payload per message", LIDAR, "mean", 285_370.0, "B", "table 4.9 5b",
                 payload_mean(LIDAR), note="ROS 2 (CDR) size"),
    ThesisFigure("payload per message", RADAR, "mean", 5_780.0, "B", "table 4.9 5a",
                 payload_mean(RADAR), note="ROS 2 (CDR) size"),
    ThesisFigure("payload per message", IMU, "mean", 32.0, "B", "table 4.9 5c",
                 payload_mean(IMU), note="the thesis's own 'accvel' type; ours sensor_msgs/Imu"),
    ThesisFigure("payload per message", CAMERA, "mean", 88.0, "B", "table 4.9 5d",
                 payload_mean(CAMERA), comparable=False, note=_IMAGE_PATH),
    # Network (table 4.10, nload over 300 s) against the four streams' payload (table 4.9).
    ThesisFigure("sensor payload per second", "", "mean", 291_270.0, "B/s", "table 4.9 5e",
                 network("sensor_payload_bytes_per_s"),
                 note="the thesis's 5e adds the four per-message sizes (docs/report.md)"),
    ThesisFigure("network load", "", "mean", 1_620_000.0, "B/s", "table 4.10 (nload, Ø300s)",
                 network("stack_bytes_per_s"),
                 note="bytes the stack's TCP sockets sent (every hop, once)"),
    ThesisFigure("network overhead", "", "ratio", 1.62e6 / 291.27e3, "x",
                 "tables 4.10 / 4.9: 1.62 MB/s / 291.27 KB/s",
                 network("stack_over_sensor_payload"),
                 note="all bytes the stack's sockets moved / the four sensor streams' payload"),
)


def thesis_comparison(run: Run) -> list[dict[str, Any]]:
    """The rows of one run: {quantity, topic, statistic, ours, thesis, source, ...}.

    ``ours`` is None when the run lacks the quantity (e.g. a topic nobody published);
    latency rows carry the p50/p99/max of the same stage as ``context``.
    """
    rows = []
    for figure in FIGURES:
        row: dict[str, Any] = {
            "quantity": figure.quantity, "topic": figure.topic,
            "statistic": figure.statistic, "ours": figure.ours(run), "thesis": figure.thesis,
            "relation": figure.relation, "unit": figure.unit, "source": figure.source,
            "comparable": figure.comparable, "note": figure.note}
        if figure.quantity == "transport" and figure.statistic == "mean":
            stage = _stage(run, figure.topic, "transport")
            row["context"] = {k: stage.get(k) for k in ("n", "p50", "p99", "max")}
        rows.append(row)
    return rows


def _fmt(value: float | None, unit: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if unit in ("B", "B/s"):
        for name, size in (("MB", 1e6), ("kB", 1e3)):
            if abs(value) >= size:
                return f"{value / size:.2f} {name}{unit[1:]}"
        return f"{value:.0f} {unit}"
    return f"{value:.2f} {unit}" if unit != "x" else f"{value:.2f}x"


def render_comparison_rows(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The rows as text lines: quantity, statistic, ours, thesis, source, note."""
    lines = [f"  {'quantity':<26}{'topic':<26}{'stat':<8}{'ours':>12}{'thesis':>14}  source"]
    for row in rows:
        thesis = row["relation"].replace("=", "") + _fmt(row["thesis"], row["unit"])
        note = row["note"] if row["comparable"] else f"NOT COMPARABLE: {row['note']}"
        lines.append(f"  {row['quantity']:<26}{row['topic'] or '(four sensor streams)':<26}"
                     f"{row['statistic']:<8}{_fmt(row['ours'], row['unit']):>12}"
                     f"{thesis:>14}  {row['source']}" + (f"; {note}" if note else ""))
    return lines
