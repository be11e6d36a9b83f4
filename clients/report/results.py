"""What the report finds, as frozen dataclasses: one run, its topics, stages, processes,
network, detection quality and thesis rows (docs/report.md).

The statistics (:mod:`clients.report.stats`, :mod:`clients.report.quality`,
:mod:`clients.report.thesis`) build these; the text (:mod:`clients.report.text`), the plots
and the ``--json`` document read them. :func:`json_ready` turns them into the JSON document
whose shape tests and scripts rely on: a field's name is its JSON key; a field's metadata
can leave it out (``JSON_NONE``), leave it out when None (``OMIT_NONE``), or merge its own
keys into its parent's (``FLATTEN``). Durations are milliseconds, sizes bytes, rates per second.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

JSON_NONE: Mapping[str, bool] = {"json": False}
"""Field metadata: not written to JSON (working data such as the plots' raw values)."""
OMIT_NONE: Mapping[str, bool] = {"omit_none": True}
"""Field metadata: the key is left out while the value is None."""
FLATTEN: Mapping[str, bool] = {"flatten": True}
"""Field metadata: the value's keys go into the parent object (a mapping or a dataclass)."""


@dataclass(frozen=True)
class StageStats:
    """One stage's durations over a run (ms): count, mean and percentiles (numpy, linear)."""

    n: int
    mean: float = math.nan
    p50: float = math.nan
    p90: float = math.nan
    p99: float = math.nan
    max: float = math.nan


@dataclass(frozen=True)
class ThesisMeans:
    """The thesis's mean (Ø, table A.1) of a topic's stages, beside ours.

    JSON: ``{"statistic": "mean", "sources": {stage: source}, "not_comparable": [stage],
    stage: ms, ...}``.
    """

    statistic: str = "mean"
    sources: Mapping[str, str] = field(default_factory=dict)
    not_comparable: tuple[str, ...] = ()
    means: Mapping[str, float] = field(default_factory=dict, metadata=FLATTEN)


@dataclass(frozen=True)
class TopicSummary:
    """Rate, bytes, per-stage statistics and deadline misses of one topic.

    payload_bytes : CDR bytes (the thesis's table 4.9), median per message; wire bytes are the
    websocket payload into (``wire_in``) and out of (``wire_out``) the bridge; ``overhead_*``
    their ratio to the payload (the encoding ratio of one hop).
    """

    messages: int
    rate_hz: float
    period_ms: float
    payload_bytes: int
    wire_in_bytes: int
    wire_out_bytes: int
    payload_bytes_mean: float
    overhead_in: float
    overhead_out: float
    subscribers: tuple[str, ...]
    stages: Mapping[str, StageStats]
    deadline_misses: int
    result_deadline_misses: int
    unprocessed: int
    thesis: ThesisMeans

    def stage(self, name: str) -> StageStats | None:
        """The statistics of stage ``name``, None when it was not traced."""
        return self.stages.get(name)


@dataclass(frozen=True)
class ProcessSummary:
    """One process over the window (its ProcessStats messages): CPU, memory, counters."""

    process: str = field(metadata=JSON_NONE)  # the key of Run.processes
    samples: int
    cpu_percent_mean: float
    cpu_percent_max: float
    rss_bytes_max: int
    pid: int
    host: str
    messages_out: int
    messages_in: int
    bytes_out: int
    bytes_in: int
    dropped: int


@dataclass(frozen=True)
class ThesisNetwork:
    """Tables 4.10 / 4.9: 1.62 MB/s of network load for 291.27 KB/s of sensor payload."""

    wire_bytes_per_s: float = 1.62e6
    payload_bytes_per_s: float = 291.27e3
    overhead: float = 1.62e6 / 291.27e3


THESIS_NETWORK = ThesisNetwork()


@dataclass(frozen=True)
class NetworkSummary:
    """The network load the thesis's way and the encoding ratio (docs/report.md).

    ``stack_*``: bytes the stack's TCP sockets sent (each hop once); ``loopback_*``: ``lo``'s
    transmit counter (every program on the machine); ``*_over_sensor_payload``: over the four
    sensor streams' payload per second; ``wire_over_payload``: one hop's websocket bytes over
    CDR bytes. NaN where not measured.
    """

    payload_bytes_per_s: float
    wire_in_bytes_per_s: float
    loopback_bytes_per_s: float
    wire_over_payload: float
    loopback_over_payload: float
    sensor_payload_bytes_per_s: float
    sensor_wire_in_bytes_per_s: float
    sensor_wire_over_payload: float
    stack_bytes_per_s: float
    stack_over_sensor_payload: float
    loopback_over_sensor_payload: float
    stack_bytes_per_s_by_process: Mapping[str, float]
    report_connection_bytes_per_s: float
    thesis: ThesisNetwork = THESIS_NETWORK


@dataclass(frozen=True)
class Machine:
    """Where the run was measured: CPUs and the load average at the window's end."""

    cpus: int | None
    load_average_1_5_15: tuple[float, float, float]


@dataclass(frozen=True)
class ClassCounts:
    """Detections and objects of one class, ``on_water`` or ``bank`` (docs/quality.md).

    detections : boxes or targets judged to lie in this class's place (on such an object, or a
    false one on open water / on land); true_detections : those on an object of this class;
    objects : visible objects of this class, summed over scans; detected_objects : of those,
    the ones some detection lies on.
    """

    detections: int = 0
    true_detections: int = 0
    objects: int = 0
    detected_objects: int = 0

    def __add__(self, other: ClassCounts) -> ClassCounts:
        summed: ClassCounts = _summed(self, other)
        return summed


@dataclass(frozen=True)
class LidarCounts:
    """LIDAR boxes against the truth, one scan or pooled (docs/quality.md)."""

    boxes: int = 0
    on_water: ClassCounts = ClassCounts()
    bank: ClassCounts = ClassCounts()

    def __add__(self, other: LidarCounts) -> LidarCounts:
        summed: LidarCounts = _summed(self, other)
        return summed


@dataclass(frozen=True)
class RadarCounts:
    """Radar targets and cells against the truth, one sweep or pooled (docs/quality.md).

    on_land : targets whose strongest cell is bare terrain (false bank targets);
    on_open_water : targets on water-only or empty cells (false on-water targets).
    """

    targets: int = 0
    on_water: ClassCounts = ClassCounts()
    bank: ClassCounts = ClassCounts()
    on_land: int = 0
    on_open_water: int = 0
    open_water_cells: int = 0
    open_water_detections: int = 0

    def __add__(self, other: RadarCounts) -> RadarCounts:
        summed: RadarCounts = _summed(self, other)
        return summed


def _summed(a: Any, b: Any) -> Any:
    """Field-by-field sum of two counts dataclasses of the same type."""
    names = [f.name for f in dataclasses.fields(a)]
    return type(a)(*(getattr(a, n) + getattr(b, n) for n in names))


def _ratio(num: int, den: int) -> float:
    return num / den if den else math.nan


@dataclass(frozen=True)
class ClassQuality:
    """Precision and recall of one class; NaN when there was nothing to divide by (which
    never meets a target)."""

    counts: ClassCounts = field(metadata=FLATTEN)
    precision: float
    recall: float

    @classmethod
    def of(cls, counts: ClassCounts) -> ClassQuality:
        return cls(
            counts,
            precision=_ratio(counts.true_detections, counts.detections),
            recall=_ratio(counts.detected_objects, counts.objects),
        )


@dataclass(frozen=True)
class LidarQuality:
    """The LIDAR boxes' quality per class, pooled over ``scans``; the matching's limits."""

    scans: int
    boxes: int
    on_water: ClassQuality
    bank: ClassQuality
    min_returns: int
    range_m: float
    margin_m: float
    water_band_m: float


@dataclass(frozen=True)
class RadarQuality:
    """The radar targets' quality per class and open-water false alarms over ``sweeps``."""

    sweeps: int
    targets: int
    on_water: ClassQuality
    bank: ClassQuality
    on_land: int
    on_open_water: int
    open_water_cells: int
    open_water_detections: int
    open_water_false_alarm_rate: float
    configured_false_alarm_rate: float


@dataclass(frozen=True)
class DetectionQuality:
    """Navigation's outputs judged against the simulator's truth; None without pairs."""

    lidar: LidarQuality | None = field(default=None, metadata=OMIT_NONE)
    radar: RadarQuality | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class StageContext:
    """The spread of a stage beside a thesis mean: n, p50, p99, max (None when untraced)."""

    n: int | None
    p50: float | None
    p99: float | None
    max: float | None


@dataclass(frozen=True)
class ThesisRow:
    """One of the thesis's figures beside the same statistic of ours (clients.report.thesis).

    ours : None when the run lacks the quantity. relation : "=", "<", ">" or "~".
    """

    quantity: str
    topic: str
    statistic: str
    ours: float | None
    thesis: float
    relation: str
    unit: str
    source: str
    comparable: bool
    note: str
    context: StageContext | None = field(default=None, metadata=OMIT_NONE)


@dataclass(frozen=True)
class Latency:
    """Durations (ms) of one quantity: mean and percentiles (numpy, linear), and how many."""

    mean: float = math.nan
    p50: float = math.nan
    p99: float = math.nan
    max: float = math.nan
    n: int = field(default=0, metadata=JSON_NONE)


@dataclass(frozen=True)
class ClosedLoop:
    """Perception -> actuation with an autopilot (docs/guidance.md), per sensor topic.

    perception_to_actuation_ms : sensor topic -> scan stamp (capture) -> the first command
    that used navigation's result of it, applied by the simulator's physics.
    hops_ms : sensor topic -> hop -> mean ms: `navigation` (capture -> result ready),
    `to_guidance` (-> guidance decoded it), `guidance` (-> its command published),
    `to_actuation` (-> the simulator applied the command).
    control_period_ms / control_jitter_ms : spacing of guidance's command stamps, and its
    standard deviation.
    """

    perception_to_actuation_ms: Mapping[str, Latency]
    hops_ms: Mapping[str, Mapping[str, float]]
    control_period_ms: Latency
    control_jitter_ms: float
    commands: int


@dataclass(frozen=True)
class Mission:
    """How the run went, from the simulator's ground truth (clients.report.mission)."""

    distance_m: float
    cross_track_rms_m: float
    min_clearance_m: float
    collisions: int


@dataclass(frozen=True)
class ShoreTopic:
    """One topic as a shore client got it: rate, share of what was published, ages (ms)."""

    topic: str
    received: int
    per_s: float
    delivered_share: float | None
    age_p50_ms: float | None
    age_p99_ms: float | None


@dataclass(frozen=True)
class ShoreMode:
    """One shore client: its scan subscription's options and what it got."""

    mode: str
    options: str
    imu: ShoreTopic
    lidar: ShoreTopic
    points_kept_p50: float | None = None


@dataclass(frozen=True)
class ShoreLink:
    """The stack read through an emulated link, one client per mode."""

    profile: str
    modes: tuple[ShoreMode, ...] = ()


@dataclass(frozen=True)
class Run:
    """Everything the report says about one run (one payload profile and encoding).

    spans : trace spans in the window. samples : topic -> one message described in words.
    bridge : the bridge's ``/riverbridge/stats`` answer as it came. stage_values : topic ->
    stage -> every duration (ms), for the plots; not in the JSON.
    """

    encoding: str
    duration_s: float
    hosts: tuple[str, ...] = ()
    spans: int = 0
    topics: Mapping[str, TopicSummary] = field(default_factory=dict)
    samples: Mapping[str, str] = field(default_factory=dict)
    processes: Mapping[str, ProcessSummary] = field(default_factory=dict)
    network: NetworkSummary | None = None
    bridge: Mapping[str, Any] = field(default_factory=dict)
    machine: Machine | None = None
    detection_quality: DetectionQuality = DetectionQuality()
    profile: str | None = None
    water_model: str = "unknown"
    point_fields: str = "unknown"
    thesis_comparison: tuple[ThesisRow, ...] = ()
    closed_loop: ClosedLoop | None = field(default=None, metadata=OMIT_NONE)
    mission: Mission | None = field(default=None, metadata=OMIT_NONE)
    stage_values: Mapping[str, Mapping[str, list[float]]] = field(
        default_factory=dict, metadata=JSON_NONE
    )
    # `--link`: the IMU and LIDAR read ashore through an emulated link (clients.report.shore)
    shore_link: ShoreLink | None = field(default=None, metadata=OMIT_NONE)

    @property
    def label(self) -> str:
        """``profile/encoding`` (``cbor``, ``thesis/json``, ``attached``)."""
        if self.profile in ("default", None):
            return self.encoding
        return f"{self.profile}/{self.encoding}"

    def topic(self, name: str) -> TopicSummary | None:
        return self.topics.get(name)


def json_ready(value: Any) -> Any:
    """``value`` as strict JSON values: dataclasses as objects (field metadata applied),
    tuples as lists, numpy scalars and arrays as numbers and lists, NaN and infinities as
    null."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _dataclass_json(value)
    if isinstance(value, np.ndarray | np.generic):
        value = value.tolist()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {key: json_ready(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(item) for item in value]
    return value


def _dataclass_json(value: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in dataclasses.fields(value):
        meta = item.metadata
        content = getattr(value, item.name)
        if not meta.get("json", True) or (content is None and meta.get("omit_none")):
            continue
        if meta.get("flatten"):
            out.update(json_ready(content))
        else:
            out[item.name] = json_ready(content)
    return out
