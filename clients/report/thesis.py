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

from clients.report.results import (
    NetworkSummary,
    StageContext,
    StageStats,
    ThesisRow,
    TopicSummary,
)
from schemas.catalogue import TOPICS

LIDAR, RADAR, CAMERA, IMU = (TOPICS[key].name for key in ("lidar", "radar", "camera", "imu"))
PUBLISH_SIDE = ("generate", "publish_wait", "encode", "send")  # the simulator's share
STATISTICS = ("mean", "p50", "max", "max-p50", "ratio")


@dataclass(frozen=True)
class Measured:
    """What a figure of ours is taken from: a run's topics and its network summary."""

    topics: Mapping[str, TopicSummary]
    network: NetworkSummary | None = None

    def stage(self, topic: str, stage: str) -> StageStats | None:
        summary = self.topics.get(topic)
        return summary.stage(stage) if summary is not None else None


Extract = Callable[[Measured], float | None]


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


def _of_stage(
    quantity: str,
    topic: str,
    stage: str,
    statistic: str,
    thesis: float,
    source: str,
    **details: Any,
) -> ThesisFigure:
    """A figure compared with one stage's ``statistic`` of ``topic`` (milliseconds)."""
    return ThesisFigure(
        quantity,
        topic,
        statistic,
        thesis,
        "ms",
        source,
        stage_stat(topic, stage, statistic),
        stage=stage,
        **details,
    )


def stage_stat(topic: str, stage: str, statistic: str) -> Extract:
    """``statistic`` (mean, p50, max, max-p50) of one stage of one topic."""

    def extract(run: Measured) -> float | None:
        values = run.stage(topic, stage)
        if values is None or not values.n:
            return None
        if statistic == "max-p50":
            return values.max - values.p50
        return float(getattr(values, statistic))

    return extract


def stage_mean_sum(topic: str, stages: Sequence[str]) -> Extract:
    """Sum of the stages' means: the mean of their sum (the mean is linear), as table A.1's
    "Sum" column adds the means of a class's methods."""

    def extract(run: Measured) -> float | None:
        means = [run.stage(topic, s) for s in stages]
        return None if any(m is None for m in means) else sum(m.mean for m in means if m)

    return extract


def payload_mean(topic: str) -> Extract:
    def extract(run: Measured) -> float | None:
        summary = run.topics.get(topic)
        return summary.payload_bytes_mean if summary and summary.payload_bytes_mean else None

    return extract


def network(key: str) -> Extract:
    def extract(run: Measured) -> float | None:
        value = getattr(run.network, key) if run.network is not None else None
        return None if value is None or math.isnan(value) else float(value)

    return extract


_A1 = "table A.1"
_IMAGE_PATH = (
    "the thesis's image message carried an 88-byte file path; the JPEG went "
    "through the disk (3.5.3), ours carries the JPEG"
)
FIGURES: tuple[ThesisFigure, ...] = (
    # Transport Unity3d -> ROS2 (table A.1, 5a-5d: "the time that is needed for a
    # transmission from Unity3d to ROS"); ours: publisher ready -> subscriber decoded.
    _of_stage(
        "transport",
        LIDAR,
        "transport",
        "mean",
        86.0,
        f"{_A1} 5b",
        note="payload differs unless --profile thesis",
    ),
    _of_stage("transport", RADAR, "transport", "mean", 30.0, f"{_A1} 5a"),
    _of_stage("transport", IMU, "transport", "mean", 9.0, f"{_A1} 5c"),
    _of_stage(
        "transport",
        CAMERA,
        "transport",
        "mean",
        6.0,
        f"{_A1} 5d",
        comparable=False,
        note=_IMAGE_PATH,
    ),
    _of_stage(
        "transport",
        IMU,
        "transport",
        "p50",
        10.0,
        "4.3, figure 4.4",
        relation="<",
        note='"a median of below 10ms"',
    ),
    _of_stage(
        "transport",
        IMU,
        "transport",
        "max",
        80.0,
        "4.3, figure 4.4",
        relation=">",
        note='"transmission times of above 80ms are possible"',
    ),
    _of_stage(
        "transport",
        LIDAR,
        "transport",
        "max-p50",
        50.0,
        "4.3, figure 4.4",
        relation="~",
        note='"the difference of the median to the highest latency value ... about 50ms"',
    ),
    # The Unity3d side per message (table A.1's "Sum" column of each sensor's methods):
    # ours is the simulator's share, capture -> handed to the socket.
    ThesisFigure(
        "simulator per message",
        LIDAR,
        "mean",
        69.0,
        "ms",
        f"{_A1} 1k, 2a, 2b (Sum)",
        stage_mean_sum(LIDAR, PUBLISH_SIDE),
        note="ray cast 10 ms (2a) + ROS# publish 59 ms (2b) in the thesis",
    ),
    ThesisFigure(
        "simulator per message",
        RADAR,
        "mean",
        6.0,
        "ms",
        f"{_A1} 1a-1f (Sum)",
        stage_mean_sum(RADAR, PUBLISH_SIDE),
    ),
    ThesisFigure(
        "simulator per message",
        CAMERA,
        "mean",
        13.0,
        "ms",
        f"{_A1} 2c, 1g, 1h (Sum)",
        stage_mean_sum(CAMERA, PUBLISH_SIDE),
        note="Unity renders on a GPU; ours ray-casts on the CPU",
    ),
    ThesisFigure(
        "simulator per message",
        IMU,
        "mean",
        0.0,
        "ms",
        f"{_A1} 1i, 1j (Sum)",
        stage_mean_sum(IMU, PUBLISH_SIDE),
        note="below 0.5 ms, printed as 0",
    ),
    # ROS2 processing (table A.1, 3a-3h without the matplotlib visualisation 4a-4d).
    _of_stage(
        "scan -> boxes",
        LIDAR,
        "process",
        "mean",
        218.0,
        f"{_A1} 3f + 3g + 3h",
        note="DBSCAN 29 + boxes 186 + publish 3; payload differs unless --profile thesis",
    ),
    _of_stage(
        "DBSCAN",
        LIDAR,
        "process.dbscan",
        "mean",
        29.0,
        f"{_A1} 3f",
        comparable=False,
        note="the thesis clustered the whole cloud; ours the ~1k voxels left after the "
        "water/terrain filter",
    ),
    _of_stage(
        "bounding boxes",
        LIDAR,
        "process.boxes",
        "mean",
        186.0,
        f"{_A1} 3g",
        comparable=False,
        note="the thesis boxed clusters of the whole cloud; ours of the obstacle points",
    ),
    _of_stage(
        "CFAR -> detections",
        RADAR,
        "process",
        "mean",
        2.0,
        f"{_A1} 3a + 3b",
        note="ours also groups the cells into targets",
    ),
    _of_stage(
        "image -> lines",
        CAMERA,
        "process",
        "mean",
        17.0,
        f"{_A1} 3c + 3d + 3e",
        note="the thesis read the JPEG from disk (3c)",
    ),
    # Message sizes (table 4.9, "Size Ø100": the average of 100 messages; KB read as 1000 B).
    ThesisFigure(
        "payload per message",
        LIDAR,
        "mean",
        285_370.0,
        "B",
        "table 4.9 5b",
        payload_mean(LIDAR),
        note="ROS 2 (CDR) size",
    ),
    ThesisFigure(
        "payload per message",
        RADAR,
        "mean",
        5_780.0,
        "B",
        "table 4.9 5a",
        payload_mean(RADAR),
        note="ROS 2 (CDR) size",
    ),
    ThesisFigure(
        "payload per message",
        IMU,
        "mean",
        32.0,
        "B",
        "table 4.9 5c",
        payload_mean(IMU),
        note="the thesis's own 'accvel' type; ours sensor_msgs/Imu",
    ),
    ThesisFigure(
        "payload per message",
        CAMERA,
        "mean",
        88.0,
        "B",
        "table 4.9 5d",
        payload_mean(CAMERA),
        comparable=False,
        note=_IMAGE_PATH,
    ),
    # Network (table 4.10, nload over 300 s) against the four streams' payload (table 4.9).
    ThesisFigure(
        "sensor payload per second",
        "",
        "mean",
        291_270.0,
        "B/s",
        "table 4.9 5e",
        network("sensor_payload_bytes_per_s"),
        note="the thesis's 5e adds the four per-message sizes (docs/report.md)",
    ),
    ThesisFigure(
        "network load",
        "",
        "mean",
        1_620_000.0,
        "B/s",
        "table 4.10 (nload, Ø300s)",
        network("stack_bytes_per_s"),
        note="bytes the stack's TCP sockets sent (every hop, once)",
    ),
    ThesisFigure(
        "network overhead",
        "",
        "ratio",
        1.62e6 / 291.27e3,
        "x",
        "tables 4.10 / 4.9: 1.62 MB/s / 291.27 KB/s",
        network("stack_over_sensor_payload"),
        note="all bytes the stack's sockets moved / the four sensor streams' payload",
    ),
)


def thesis_comparison(run: Measured) -> tuple[ThesisRow, ...]:
    """The rows of one run: {quantity, topic, statistic, ours, thesis, source, ...}.

    ``ours`` is None when the run lacks the quantity (e.g. a topic nobody published);
    the transport means carry the n/p50/p99/max of the same stage as ``context``.
    """
    rows = []
    for figure in FIGURES:
        context = None
        if figure.quantity == "transport" and figure.statistic == "mean":
            stage = run.stage(figure.topic, "transport")
            context = (
                StageContext(stage.n, stage.p50, stage.p99, stage.max)
                if stage is not None
                else StageContext(None, None, None, None)
            )
        rows.append(
            ThesisRow(
                quantity=figure.quantity,
                topic=figure.topic,
                statistic=figure.statistic,
                ours=figure.ours(run),
                thesis=figure.thesis,
                relation=figure.relation,
                unit=figure.unit,
                source=figure.source,
                comparable=figure.comparable,
                note=figure.note,
                context=context,
            )
        )
    return tuple(rows)
