"""One run's report from what its window saw: pure, so it is testable without a stack.

:mod:`clients.report.measure` gathers :class:`Observations` through the bridge (trace spans,
process stats, navigation's outputs and the truth, the simulator's configuration, socket and
loopback counters); :func:`build_run` turns them into a :class:`clients.report.results.Run`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from clients.report.closed_loop import closed_loop
from clients.report.journeys import SpanRecord, by_topic, hosts_of, journeys, stage_values
from clients.report.mission import AutopilotSeen, mission
from clients.report.quality import lidar_quality, pair_by_stamp, radar_quality
from clients.report.results import DetectionQuality, Machine, ProcessSummary, Run, ShoreLink
from clients.report.sockets import SocketBytes, SocketTraffic, window_traffic
from clients.report.stats import network_summary, process_summary, topic_summary
from clients.report.thesis import Measured, thesis_comparison
from schemas.catalogue import TOPICS

STACK_PROCESSES = ("bridge", "simulator", "navigation")
# What the detection quality reads (docs/quality.md): the truth and navigation's outputs.
QUALITY_TOPICS = {
    "lidar_truth": TOPICS["lidar_truth"].pair,
    "radar_truth": TOPICS["radar_truth"].pair,
    "boxes": TOPICS["boxes"].pair,
    "radar": TOPICS["radar_detections"].pair,
}

Message = Mapping[str, Any]


@dataclass(frozen=True)
class Observations:
    """What one measurement window saw, as it came.

    judged : QUALITY_TOPICS key -> the messages stamped in the window. sim_config : the
    simulator's latched ``/sim/config`` message, if any. sockets_before/after : ``ss``
    snapshots at the window's ends (None without ``ss``). report_pid : the measuring process,
    whose connection is counted apart.
    """

    encoding: str
    duration_s: float
    spans: Sequence[SpanRecord]
    process_stats: Sequence[Message] = ()
    bridge_stats: Message | None = None
    judged: Mapping[str, Sequence[Message]] | None = None
    sim_config: Message | None = None
    samples: Mapping[str, str] | None = None
    loopback_bytes: int | None = None
    sockets_before: Sequence[SocketBytes] | None = None
    sockets_after: Sequence[SocketBytes] | None = None
    report_pid: int = 0
    machine: Machine | None = None
    profile: str | None = None
    autopilot: AutopilotSeen | None = None
    shore_link: ShoreLink | None = None


def build_run(seen: Observations) -> Run:
    """Everything the report says about one run."""
    grouped = by_topic(journeys(seen.spans))
    topics = {t: topic_summary(t, items, seen.duration_s) for t, items in grouped.items()}
    processes = process_summary(seen.process_stats)
    network = network_summary(
        topics, seen.loopback_bytes, seen.duration_s, stack_traffic(seen, processes)
    )
    profile, water_model, point_fields = simulator_settings(seen.sim_config, seen.profile)
    return Run(
        encoding=seen.encoding,
        duration_s=seen.duration_s,
        hosts=tuple(hosts_of(seen.spans)),
        spans=len(seen.spans),
        topics=topics,
        samples=dict(seen.samples or {}),
        processes=processes,
        network=network,
        bridge=dict(seen.bridge_stats or {}),
        machine=seen.machine,
        detection_quality=detection_quality(seen.judged or {}),
        profile=profile,
        water_model=water_model,
        point_fields=point_fields,
        thesis_comparison=thesis_comparison(Measured(topics, network)),
        closed_loop=closed_loop(seen.spans),
        mission=mission(seen.autopilot) if seen.autopilot is not None else None,
        stage_values={t: stage_values(items) for t, items in grouped.items()},
        shore_link=seen.shore_link,
    )


def stack_traffic(
    seen: Observations, processes: Mapping[str, ProcessSummary]
) -> SocketTraffic | None:
    """What the stack's processes' sockets sent in the window (clients.report.sockets)."""
    if seen.sockets_before is None or seen.sockets_after is None:
        return None
    pids = {p.pid: name for name, p in processes.items() if name in STACK_PROCESSES}
    return window_traffic(seen.sockets_before, seen.sockets_after, pids, [seen.report_pid])


def detection_quality(judged: Mapping[str, Sequence[Message]]) -> DetectionQuality:
    """Precision and recall of LIDAR boxes and radar targets (clients.report.quality)."""
    lidar = pair_by_stamp(judged.get("lidar_truth", ()), judged.get("boxes", ()))
    radar = pair_by_stamp(judged.get("radar_truth", ()), judged.get("radar", ()))
    return DetectionQuality(
        lidar=lidar_quality(lidar) if lidar else None, radar=radar_quality(radar) if radar else None
    )


def simulator_settings(config_msg: Message | None, profile: str | None) -> tuple[str, str, str]:
    """The profile, LIDAR water model and point fields the simulator ran with (its latched
    /sim/config); ``profile`` (else "unknown") and "unknown" where it does not say."""
    try:
        config = json.loads(config_msg["data"]) if config_msg else {}
    except (KeyError, TypeError, ValueError):
        config = {}
    config = config if isinstance(config, dict) else {}
    lidar = config.get("lidar")
    lidar = lidar if isinstance(lidar, dict) else {}
    return (
        str(config.get("profile", profile or "unknown")),
        str(lidar.get("water_model", "unknown")),
        str(lidar.get("point_fields", "unknown")),
    )


def vessel_hull_m(config_msg: Message | None) -> tuple[float, float]:
    """The hull's (length, beam) in metres from the simulator's /sim/config, else its
    defaults (simulator.config.VesselConfig)."""
    try:
        vessel = json.loads(config_msg["data"])["vessel"] if config_msg else {}
        return float(vessel["length_m"]), float(vessel["beam_m"])
    except (KeyError, TypeError, ValueError):
        return 7.0, 2.5


def describe_sample(topic: str, msg: Message) -> str:
    """The payload of one sensor message in words (points per scan, cells, bytes)."""
    if topic == TOPICS["lidar"].name:
        return f"{int(msg['width']) * int(msg['height']):,} points x {msg['point_step']} B"
    if topic == TOPICS["radar"].name:
        return f"{msg['num_beams']} beams x {msg['num_cells']} cells float32"
    if topic == TOPICS["camera"].name:
        return f"{msg['format']} {len(msg['data']):,} B"
    return "one sample"
