"""The report as text: one block per run, and a table comparing the runs (docs/report.md).

Every table is a list of columns below (``*_COLUMNS``, :class:`clients.report.table.Column`),
and the comparison's rows are lists of quantities (``*_QUANTITIES``): a new column or a new
compared quantity is one entry. Latency rows print the mean (the statistic of the thesis's
appendix A, Ø) beside the thesis's figure and its source, then p50/p90/p99/max; bytes are CDR
payload (the thesis's table 4.9) and websocket wire bytes, whose ratio is an *encoding ratio*
of one hop; the network overhead the thesis's way (table 4.10 over 4.9) counts every byte the
stack's sockets sent.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

from clients.report.closed_loop import HOPS
from clients.report.journeys import RESULT, TRANSPORT, stage_order
from clients.report.quality import TARGET_PRECISION, TARGET_RECALL, shortfalls
from clients.report.results import (
    THESIS_NETWORK,
    ClassQuality,
    ClosedLoop,
    DetectionQuality,
    Latency,
    LidarQuality,
    Mission,
    NetworkSummary,
    ProcessSummary,
    RadarQuality,
    Run,
    ShoreLink,
    ShoreTopic,
    StageStats,
    ThesisRow,
    TopicSummary,
)
from clients.report.stats import SENSOR_TOPICS
from clients.report.table import (
    Column,
    fmt_bytes,
    fmt_float1,
    fmt_fraction,
    fmt_ms,
    fmt_ratio,
    fmt_ratio3,
    render_table,
    text_column,
)
from clients.report.thesis import FIGURES


def _hop(hop: str) -> Callable[[LoopLine], float | None]:
    return lambda line: line.hops.get(hop)


class TopicLine(NamedTuple):
    topic: str
    summary: TopicSummary
    sample: str


class StageLine(NamedTuple):
    stage: str
    stats: StageStats
    note: str


class ComparisonLine(NamedTuple):
    topic: str
    quantity: str
    cells: tuple[str, ...]
    thesis: str = ""
    source: str = ""


def fmt_unit(value: float | None, unit: str) -> str:
    """A thesis row's value in its unit: ``12.30 ms``, ``2.86 MB/s``, ``5.56x``."""
    if value is None or value != value:  # None or NaN
        return "-"
    if unit in ("B", "B/s"):
        return fmt_bytes(value) + unit[1:] if abs(value) >= 1e3 else f"{value:.0f} {unit}"
    return f"{value:.2f}x" if unit == "x" else f"{value:.2f} {unit}"


# -- the tables of one run -------------------------------------------------------------------

TOPIC_COLUMNS: tuple[Column[TopicLine], ...] = (
    text_column("topic", "topic"),
    Column("rate", "summary.rate_hz", fmt_float1, "Hz"),
    Column("period", "summary.period_ms", fmt_ms, "ms"),
    Column("payload", "summary.payload_bytes", fmt_bytes),
    Column("wire in", "summary.wire_in_bytes", fmt_bytes),
    Column("wire out", "summary.wire_out_bytes", fmt_bytes),
    Column("encoding ratio", "summary.overhead_in", fmt_ratio3),
    text_column("sample", "sample"),
)

STAGE_COLUMNS: tuple[Column[StageLine], ...] = (
    text_column("stage (ms)", "stage"),
    Column("n", "stats.n"),
    Column("mean", "stats.mean", fmt_ms),
    Column("p50", "stats.p50", fmt_ms),
    Column("p90", "stats.p90", fmt_ms),
    Column("p99", "stats.p99", fmt_ms),
    Column("max", "stats.max", fmt_ms),
    text_column("beside the thesis; deadlines", "note"),
)

PROCESS_COLUMNS: tuple[Column[ProcessSummary], ...] = (
    text_column("process", "process"),
    Column("cpu % mean", "cpu_percent_mean", fmt_float1),
    Column("cpu % max", "cpu_percent_max", fmt_float1),
    Column("rss max", "rss_bytes_max", fmt_bytes),
    Column("msgs out", "messages_out"),
    Column("msgs in", "messages_in"),
    Column("dropped", "dropped"),
)


def _thesis_source(row: ThesisRow) -> str:
    note = row.note if row.comparable else f"NOT COMPARABLE: {row.note}"
    return row.source + (f"; {note}" if note else "")


THESIS_COLUMNS: tuple[Column[ThesisRow], ...] = (
    text_column("quantity", "quantity"),
    text_column("topic", lambda row: row.topic or "(four sensor streams)"),
    text_column("stat", "statistic"),
    Column("ours", lambda row: fmt_unit(row.ours, row.unit)),
    Column("thesis", lambda row: row.relation.replace("=", "") + fmt_unit(row.thesis, row.unit)),
    text_column("source", _thesis_source),
)


def _thesis_note(stage: str, summary: TopicSummary) -> str:
    thesis = summary.thesis
    if stage not in thesis.means:
        return ""
    note = f"thesis Ø {thesis.means[stage]:g} ms ({thesis.sources[stage]})"
    return note + (" NOT COMPARABLE" if stage in thesis.not_comparable else "")


def _stage_lines(summary: TopicSummary) -> list[StageLine]:
    lines = []
    for stage in stage_order(summary.stages):
        stats = summary.stages[stage]
        if not stats.n:
            continue
        notes = [_thesis_note(stage, summary)]
        if stage == TRANSPORT:
            notes.append(f"misses {summary.deadline_misses}/{stats.n}")
        if stage == RESULT:
            notes.append(
                f"misses {summary.result_deadline_misses}/{stats.n}, "
                f"unprocessed {summary.unprocessed}"
            )
        lines.append(StageLine(stage, stats, "; ".join(n for n in notes if n)))
    return lines


def _header(run: Run) -> list[str]:
    hosts = run.hosts
    lines = [
        f"== {run.label}: {run.duration_s:.1f} s measured on "
        f"{', '.join(hosts) or 'unknown host'}"
        + (" (HOSTS DIFFER: cross-process hops are not comparable)" if len(hosts) > 1 else "")
    ]
    if run.profile:
        lines.append(f"   payload profile {run.profile}; LIDAR water model {run.water_model}")
    if run.machine is not None:
        load = run.machine.load_average_1_5_15
        lines.append(
            f"   machine: {run.machine.cpus} CPUs, load average {load[0]:.1f} / "
            f"{load[1]:.1f} / {load[2]:.1f} (1/5/15 min) at the window's end"
        )
    return lines


def render_run(run: Run) -> str:
    """The human-readable report of one run (one profile and encoding)."""
    lines = _header(run)
    lines += render_table(
        TOPIC_COLUMNS,
        [
            TopicLine(topic, summary, run.samples.get(topic, ""))
            for topic, summary in run.topics.items()
        ],
    )
    for topic, summary in run.topics.items():
        stages = _stage_lines(summary)
        if stages:
            lines.append(f"  {topic}")
            lines += render_table(STAGE_COLUMNS, stages, indent="    ")
    if run.processes:
        lines += render_table(PROCESS_COLUMNS, list(run.processes.values()))
    if run.network is not None:
        lines += _network_lines(run.network)
    lines += _quality_lines(run.detection_quality)
    if run.thesis_comparison:
        lines.append("  beside the thesis (same statistic; docs/report.md):")
        lines += render_table(THESIS_COLUMNS, run.thesis_comparison)
    if run.closed_loop is not None:
        lines += _closed_loop_lines(run.closed_loop)
    if run.mission is not None:
        lines += _mission_lines(run.mission)
    if run.shore_link is not None:
        lines += _shore_lines(run.shore_link)
    return "\n".join(lines)


class LoopLine(NamedTuple):
    topic: str
    total: Latency
    hops: dict[str, float]


LOOP_COLUMNS: list[Column[LoopLine]] = [
    text_column("sensor", "topic"),
    Column("n", "total.n", str),
    *(
        Column(statistic, f"total.{statistic}", fmt_ms, "ms")
        for statistic in ("mean", "p50", "p99", "max")
    ),
    *(Column(hop, _hop(hop), fmt_ms, "ms") for hop in HOPS),
]


def _closed_loop_lines(loop: ClosedLoop) -> list[str]:
    period = loop.control_period_ms
    lines = [
        "  closed loop (docs/guidance.md): perception -> actuation, scan capture -> the first "
        "command using it applied by the simulator; hop columns are means",
    ]
    lines += render_table(
        LOOP_COLUMNS,
        [
            LoopLine(topic, total, dict(loop.hops_ms.get(topic, {})))
            for topic, total in loop.perception_to_actuation_ms.items()
        ],
    )
    lines.append(
        f"  control loop: {loop.commands} commands, period mean {fmt_ms(period.mean)} ms "
        f"(p99 {fmt_ms(period.p99)}, max {fmt_ms(period.max)}), jitter (std) "
        f"{fmt_ms(loop.control_jitter_ms)} ms"
    )
    return lines


class ShoreLine(NamedTuple):
    mode: str
    topic: ShoreTopic
    points_kept_p50: float | None


SHORE_COLUMNS: list[Column[ShoreLine]] = [
    text_column("mode", "mode"),
    text_column("topic", "topic.topic"),
    Column("rate", "topic.per_s", fmt_float1, "/s"),
    Column("delivered", "topic.delivered_share", fmt_fraction),
    Column("age p50", "topic.age_p50_ms", fmt_ms, "ms"),
    Column("age p99", "topic.age_p99_ms", fmt_ms, "ms"),
    Column("points", "points_kept_p50", fmt_float1),
]


def _shore_lines(shore: ShoreLink) -> list[str]:
    """The IMU and LIDAR as shore clients got them through the emulated link, per mode."""
    rows = [
        ShoreLine(mode.mode, topic, mode.points_kept_p50 if topic is mode.lidar else None)
        for mode in shore.modes
        for topic in (mode.imu, mode.lidar)
    ]
    options = "; ".join(f"{mode.mode} {mode.options}" for mode in shore.modes)
    return [
        f"  ashore over the emulated {shore.profile} link, one client per mode on a link of its"
        f" own (docs/bridge.md 'Over a thin link'); scan options: {options}",
        *render_table(SHORE_COLUMNS, rows),
    ]


def _mission_lines(mission: Mission) -> list[str]:
    return [
        f"  mission (simulator ground truth): {mission.distance_m:.1f} m travelled, "
        f"cross-track RMS {mission.cross_track_rms_m:.2f} m, least clearance "
        f"{mission.min_clearance_m:.1f} m, {mission.collisions} collisions"
    ]


def _network_lines(network: NetworkSummary) -> list[str]:
    by_process = ", ".join(
        f"{name} {fmt_bytes(bps)}/s" for name, bps in network.stack_bytes_per_s_by_process.items()
    )
    thesis = network.thesis
    return [
        f"  network, the thesis's way (table 4.10 / 4.9): the stack's sockets sent "
        f"{fmt_bytes(network.stack_bytes_per_s)}/s ({by_process or 'not measured'})"
        f" for {fmt_bytes(network.sensor_payload_bytes_per_s)}/s of sensor payload = "
        f"{fmt_ratio(network.stack_over_sensor_payload)} (thesis "
        f"{fmt_bytes(thesis.wire_bytes_per_s)}/s for {fmt_bytes(thesis.payload_bytes_per_s)}/s"
        f" = {thesis.overhead:.2f}x); machine loopback "
        f"{fmt_bytes(network.loopback_bytes_per_s)}/s = "
        f"{fmt_ratio(network.loopback_over_sensor_payload)} (every program here); "
        f"the report's own connection {fmt_bytes(network.report_connection_bytes_per_s)}"
        f"/s, not counted",
        f"  encoding ratio (one hop's websocket bytes / CDR bytes): sensor streams "
        f"({', '.join(SENSOR_TOPICS)}) {fmt_ratio(network.sensor_wire_over_payload, 3)}, "
        f"all topics {fmt_ratio(network.wire_over_payload, 3)} "
        f"(payload {fmt_bytes(network.payload_bytes_per_s)}/s, wire "
        f"{fmt_bytes(network.wire_in_bytes_per_s)}/s)",
    ]


def _quality_lines(quality: DetectionQuality) -> list[str]:
    rows = []
    lidar, radar = quality.lidar, quality.radar
    if lidar is not None:
        rows.append(
            f"  detection quality, LIDAR boxes ({lidar.scans} scans, {lidar.boxes} boxes; an "
            f"object counts with >= {lidar.min_returns} returns, within {lidar.range_m:g} m "
            "for recall):"
        )
        rows += _class_lines(lidar.on_water, lidar.bank, "boxes")
        rows.append(_verdict(lidar))
    if radar is not None:
        rows.append(
            f"  detection quality, radar targets ({radar.sweeps} sweeps, {radar.targets} "
            f"targets: {radar.on_land} on bare land, {radar.on_open_water} on open water):"
        )
        rows += _class_lines(radar.on_water, radar.bank, "targets")
        rows.append(
            f"    open water: {radar.open_water_detections}/{radar.open_water_cells} cells "
            f"detected = {fmt_fraction(radar.open_water_false_alarm_rate, 4)} (configured "
            f"P_fa {radar.configured_false_alarm_rate:g})"
        )
        rows.append(_verdict(radar))
    return rows


def _class_lines(on_water: ClassQuality, bank: ClassQuality, unit: str) -> list[str]:
    return [
        f"    {name:<8} precision {fmt_fraction(q.precision)} ({q.counts.true_detections}/"
        f"{q.counts.detections} {unit} on {what}), recall {fmt_fraction(q.recall)} "
        f"({q.counts.detected_objects}/{q.counts.objects} objects)"
        for name, q, what in (
            ("on_water", on_water, "obstacles in the river"),
            ("bank", bank, "trees and houses"),
        )
    ]


def _verdict(quality: LidarQuality | RadarQuality) -> str:
    missed = shortfalls(quality)
    if not missed:
        return (
            f"    on_water meets the targets (precision >= {TARGET_PRECISION}, recall >= "
            f"{TARGET_RECALL})"
        )
    return "    on_water BELOW the targets: " + "; ".join(missed)


# -- the runs side by side -------------------------------------------------------------------


@dataclass(frozen=True)
class TopicQuantity:
    """A row per sensor topic in the comparison. stage : with a thesis mean of that stage,
    its figure goes beside. optional : leave the row out when no run has a value."""

    name: str
    value: Callable[[TopicSummary], float | None]
    fmt: Callable[[float | None], str]
    stage: str = ""
    optional: bool = False


@dataclass(frozen=True)
class RunQuantity:
    """A row per comparison of whole runs (network, detection quality)."""

    topic: str
    name: str
    value: Callable[[Run], float | None]
    fmt: Callable[[float | None], str]
    thesis: str = ""
    source: str = ""


def _stage_stat(stage: str, statistic: str) -> Callable[[TopicSummary], float | None]:
    def value(summary: TopicSummary) -> float | None:
        stats = summary.stage(stage)
        return getattr(stats, statistic) if stats is not None and stats.n else None

    return value


TOPIC_QUANTITIES: tuple[TopicQuantity, ...] = (
    TopicQuantity("transport mean ms", _stage_stat(TRANSPORT, "mean"), fmt_ms, TRANSPORT, True),
    TopicQuantity("transport p50 ms", _stage_stat(TRANSPORT, "p50"), fmt_ms, optional=True),
    TopicQuantity("transport p99 ms", _stage_stat(TRANSPORT, "p99"), fmt_ms, optional=True),
    TopicQuantity("transport max ms", _stage_stat(TRANSPORT, "max"), fmt_ms, optional=True),
    TopicQuantity("result mean ms", _stage_stat(RESULT, "mean"), fmt_ms, RESULT, True),
    TopicQuantity("payload mean", lambda summary: summary.payload_bytes_mean, fmt_bytes),
    TopicQuantity("encoding ratio", lambda summary: summary.overhead_in, fmt_ratio3),
)


def _overhead(run: Run) -> float | None:
    return run.network.stack_over_sensor_payload if run.network is not None else None


def _quality(sensor: str, figure: str) -> Callable[[Run], float | None]:
    def value(run: Run) -> float | None:
        quality = getattr(run.detection_quality, sensor)
        return None if quality is None else float(getattr(quality.on_water, figure))

    return value


RUN_QUANTITIES: tuple[RunQuantity, ...] = (
    RunQuantity(
        "four sensor streams",
        "network overhead",
        _overhead,
        fmt_ratio,
        f"{THESIS_NETWORK.overhead:.2f}x",
        "tables 4.10 / 4.9",
    ),
    RunQuantity("lidar on_water", "precision", _quality("lidar", "precision"), fmt_fraction),
    RunQuantity("lidar on_water", "recall", _quality("lidar", "recall"), fmt_fraction),
    RunQuantity("radar on_water", "precision", _quality("radar", "precision"), fmt_fraction),
    RunQuantity("radar on_water", "recall", _quality("radar", "recall"), fmt_fraction),
)


def _topic_lines(runs: Sequence[Run], topic: str) -> list[ComparisonLine]:
    means = {(f.topic, f.stage): f for f in FIGURES if f.statistic == "mean" and f.stage}
    lines = []
    for quantity in TOPIC_QUANTITIES:
        values = [
            None if (summary := run.topic(topic)) is None else quantity.value(summary)
            for run in runs
        ]
        if quantity.optional and all(v is None for v in values):
            continue
        figure = means.get((topic, quantity.stage)) if quantity.stage else None
        thesis = f"{figure.thesis:g}" if figure else ""
        source = figure.source + ("" if figure.comparable else " NOT COMPARABLE") if figure else ""
        lines.append(
            ComparisonLine(
                topic, quantity.name, tuple(quantity.fmt(v) for v in values), thesis, source
            )
        )
    return lines


def render_comparison(runs: Sequence[Run]) -> str:
    """One table comparing the runs per sensor topic: the thesis's statistic (the mean)
    beside its figure, p50/p99/max, payload, ratios and detection quality."""
    lines: list[ComparisonLine] = []
    for topic in SENSOR_TOPICS:
        if any(topic in run.topics for run in runs):
            lines += _topic_lines(runs, topic)
    lines += [
        ComparisonLine(
            q.topic, q.name, tuple(q.fmt(q.value(run)) for run in runs), q.thesis, q.source
        )
        for q in RUN_QUANTITIES
    ]
    columns: list[Column[ComparisonLine]] = [
        text_column("topic", "topic"),
        text_column("quantity", "quantity"),
    ]
    columns += [Column(run.label, _cell(k)) for k, run in enumerate(runs)]
    columns += [Column("thesis", "thesis"), text_column("source", "source")]
    return "\n".join(render_table(columns, lines, indent=""))


def _cell(index: int) -> Callable[[ComparisonLine], str]:
    return lambda line: line.cells[index]
