"""The report as text: one block per run, and a table comparing the runs (docs/report.md).

Every latency row prints the mean (the statistic of the thesis's appendix A, Ø) beside the
thesis's figure and its source, then p50/p90/p99/max; bytes are CDR payload (the thesis's
table 4.9) and websocket wire bytes, whose ratio is an *encoding ratio* of one hop; the
network overhead the thesis's way (table 4.10 over 4.9) counts every byte the stack's sockets
sent. Pure formatting of the dicts ``clients.report.cli`` builds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from clients.report.stats import RESULT, SENSOR_TOPICS, THESIS_OVERHEAD, TRANSPORT, stage_order
from clients.report.thesis import FIGURES, render_comparison_rows


def fmt_bytes(count: float | None) -> str:
    if not count or math.isnan(count):
        return "-"
    for unit, size in (("MB", 1e6), ("kB", 1e3)):
        if count >= size:
            return f"{count / size:.2f} {unit}"
    return f"{count:.0f} B"


def fmt_ms(value: float | None) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.2f}"


def fmt_ratio(value: float | None, digits: int = 2) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.{digits}f}x"


def run_label(run: Mapping[str, Any]) -> str:
    """``profile/encoding`` (``cbor``, ``thesis/json``, ``attached``)."""
    profile = run.get("profile", "default")
    return run["encoding"] if profile in ("default", None) else f"{profile}/{run['encoding']}"


def _thesis_note(stage: str, summary: Mapping[str, Any]) -> str:
    thesis = summary.get("thesis", {})
    if stage not in thesis:
        return ""
    note = f"thesis Ø {thesis[stage]:g} ms ({thesis['sources'][stage]})"
    if stage in thesis.get("not_comparable", ()):
        note += " NOT COMPARABLE"
    return note


def _stage_rows(summary: Mapping[str, Any]) -> list[str]:
    rows = []
    for stage in stage_order(summary["stages"]):
        p = summary["stages"][stage]
        if not p.get("n"):
            continue
        notes = [_thesis_note(stage, summary)]
        if stage == TRANSPORT:
            notes.append(f"misses {summary['deadline_misses']}/{p['n']}")
        if stage == RESULT:
            notes.append(f"misses {summary['result_deadline_misses']}/{p['n']}, "
                         f"unprocessed {summary['unprocessed']}")
        rows.append(f"    {stage:<16}{p['n']:>6}{fmt_ms(p['mean']):>9}{fmt_ms(p['p50']):>9}"
                    f"{fmt_ms(p['p90']):>9}{fmt_ms(p['p99']):>9}{fmt_ms(p['max']):>9}   "
                    + "; ".join(n for n in notes if n))
    return rows


def _header(run: Mapping[str, Any]) -> list[str]:
    hosts = run.get("hosts", [])
    profile = run.get("profile")
    lines = [f"== {run_label(run)}: {run['duration_s']:.1f} s measured on "
             f"{', '.join(hosts) or 'unknown host'}"
             + (" (HOSTS DIFFER: cross-process hops are not comparable)" if len(hosts) > 1
                else "")]
    if profile:
        lines.append(f"   payload profile {profile}; LIDAR water model "
                     f"{run.get('water_model', 'unknown')}")
    machine = run.get("machine")
    if machine:
        load = machine["load_average_1_5_15"]
        lines.append(f"   machine: {machine['cpus']} CPUs, load average {load[0]:.1f} / "
                     f"{load[1]:.1f} / {load[2]:.1f} (1/5/15 min) at the window's end")
    return lines


def render_run(run: Mapping[str, Any]) -> str:
    """The human-readable report of one run (one profile and encoding)."""
    lines = _header(run)
    for topic, summary in run["topics"].items():
        sample = run.get("samples", {}).get(topic, "")
        lines.append(
            f"{topic}  {summary['rate_hz']:.1f} Hz (period {fmt_ms(summary['period_ms'])} ms)"
            f"  payload {fmt_bytes(summary['payload_bytes'])}  wire in "
            f"{fmt_bytes(summary['wire_in_bytes'])} / out {fmt_bytes(summary['wire_out_bytes'])}"
            f"  encoding ratio {summary['overhead_in']:.3f}x"
            + (f"  [{sample}]" if sample else ""))
        if summary["stages"]:
            lines.append(f"    {'stage (ms)':<16}{'n':>6}{'mean':>9}{'p50':>9}{'p90':>9}"
                         f"{'p99':>9}{'max':>9}")
            lines += _stage_rows(summary)
    lines += _process_rows(run.get("processes", {}))
    lines += _network_rows(run.get("network", {}))
    lines += _quality_rows(run.get("detection_quality", {}))
    if run.get("thesis_comparison"):
        lines.append("  beside the thesis (same statistic; docs/report.md):")
        lines += render_comparison_rows(run["thesis_comparison"])
    return "\n".join(lines)


def _process_rows(processes: Mapping[str, Mapping[str, Any]]) -> list[str]:
    if not processes:
        return []
    rows = [f"  {'process':<14}{'cpu % mean':>11}{'cpu % max':>10}{'rss max':>11}"
            f"{'msgs out':>10}{'msgs in':>9}{'dropped':>9}"]
    for name, p in processes.items():
        rows.append(f"  {name:<14}{p['cpu_percent_mean']:>11.1f}{p['cpu_percent_max']:>10.1f}"
                    f"{fmt_bytes(p['rss_bytes_max']):>11}{p['messages_out']:>10}"
                    f"{p['messages_in']:>9}{p['dropped']:>9}")
    return rows


def _network_rows(network: Mapping[str, Any]) -> list[str]:
    if not network:
        return []
    by_process = ", ".join(f"{name} {fmt_bytes(bps)}/s" for name, bps in
                           network.get("stack_bytes_per_s_by_process", {}).items())
    nan = math.nan
    return [
        f"  network, the thesis's way (table 4.10 / 4.9): the stack's sockets sent "
        f"{fmt_bytes(network.get('stack_bytes_per_s', nan))}/s ({by_process or 'not measured'})"
        f" for {fmt_bytes(network['sensor_payload_bytes_per_s'])}/s of sensor payload = "
        f"{fmt_ratio(network.get('stack_over_sensor_payload', nan))} (thesis 1.62 MB/s for "
        f"291.27 kB/s = {THESIS_OVERHEAD:.2f}x); machine loopback "
        f"{fmt_bytes(network['loopback_bytes_per_s'])}/s = "
        f"{fmt_ratio(network.get('loopback_over_sensor_payload', nan))} (every program here); "
        f"the report's own connection {fmt_bytes(network.get('report_connection_bytes_per_s'))}"
        f"/s, not counted",
        f"  encoding ratio (one hop's websocket bytes / CDR bytes): sensor streams "
        f"({', '.join(SENSOR_TOPICS)}) {fmt_ratio(network['sensor_wire_over_payload'], 3)}, "
        f"all topics {fmt_ratio(network['wire_over_payload'], 3)} "
        f"(payload {fmt_bytes(network['payload_bytes_per_s'])}/s, wire "
        f"{fmt_bytes(network['wire_in_bytes_per_s'])}/s)"]


def _quality_rows(quality: Mapping[str, Any]) -> list[str]:
    rows = []
    lidar, radar = quality.get("lidar"), quality.get("radar")
    if lidar:
        rows.append(
            f"  detection quality, LIDAR boxes ({lidar['scans']} scans): precision "
            f"{_fraction(lidar['precision'])} ({lidar.get('true_boxes', 0)}/"
            f"{lidar.get('boxes', 0)} boxes on objects), recall {_fraction(lidar['recall'])} "
            f"({lidar.get('detected_objects', 0)}/{lidar.get('visible_objects', 0)} objects "
            f"with >= {lidar['min_returns']} returns within {lidar['range_m']:g} m)")
    if radar:
        rows.append(
            f"  detection quality, radar targets ({radar['sweeps']} sweeps): precision "
            f"{_fraction(radar['precision'])} ({radar.get('on_object', 0)} on objects + "
            f"{radar.get('on_land', 0)} on land of {radar.get('targets', 0)} targets), recall "
            f"{_fraction(radar['recall'])} ({radar.get('detected_objects', 0)}/"
            f"{radar.get('visible_objects', 0)} objects); open water: "
            f"{radar.get('open_water_detections', 0)}/{radar.get('open_water_cells', 0)} cells "
            f"detected = {_fraction(radar['open_water_false_alarm_rate'], 4)} (configured P_fa "
            f"{radar['configured_false_alarm_rate']:g})")
    return rows


def _fraction(value: float | None, digits: int = 3) -> str:
    return "-" if value is None or math.isnan(value) else f"{value:.{digits}f}"


def render_comparison(runs: Sequence[Mapping[str, Any]]) -> str:
    """One table comparing the runs per sensor topic: the thesis's statistic (the mean)
    beside its figure, p50/p99/max, payload, ratios and detection quality."""
    labels = [run_label(r) for r in runs]
    width = max(12, *(len(label) + 2 for label in labels))
    lines = [f"{'topic':<26}{'quantity':<24}" + "".join(f"{lb:>{width}}" for lb in labels)
             + f"{'thesis':>12}  source"]

    def add(topic: str, quantity: str, cells: list[str], thesis: str = "", source: str = ""):
        lines.append(f"{topic:<26}{quantity:<24}" + "".join(f"{c:>{width}}" for c in cells)
                     + f"{thesis:>12}  {source}")

    means = {(f.topic, f.stage): f for f in FIGURES if f.statistic == "mean" and f.stage}
    for topic in [t for t in SENSOR_TOPICS if any(t in r["topics"] for r in runs)]:
        for stage, key in ((TRANSPORT, "mean"), (TRANSPORT, "p50"), (TRANSPORT, "p99"),
                           (TRANSPORT, "max"), (RESULT, "mean")):
            cells = [r["topics"].get(topic, {}).get("stages", {}).get(stage, {}).get(key)
                     for r in runs]
            if all(c is None for c in cells):
                continue
            figure = means.get((topic, stage)) if key == "mean" else None
            thesis = f"{figure.thesis:g}" if figure else ""
            source = (figure.source + ("" if figure.comparable else " NOT COMPARABLE")
                      if figure else "")
            add(topic, f"{stage} {key} ms", [fmt_ms(c) for c in cells], thesis, source)
        add(topic, "payload mean", [fmt_bytes(r["topics"].get(topic, {}).get(
            "payload_bytes_mean")) for r in runs])
        add(topic, "encoding ratio", [fmt_ratio(r["topics"].get(topic, {}).get(
            "overhead_in", math.nan), 3) for r in runs])
    add("four sensor streams", "network overhead", [fmt_ratio(r.get("network", {}).get(
        "stack_over_sensor_payload", math.nan)) for r in runs], f"{THESIS_OVERHEAD:.2f}x",
        "tables 4.10 / 4.9")
    for sensor in ("lidar", "radar"):
        for key in ("precision", "recall"):
            add(f"{sensor} quality", key, [_fraction(r.get("detection_quality", {}).get(
                sensor, {}).get(key)) for r in runs])
    return "\n".join(lines)
