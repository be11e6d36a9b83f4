"""One run built from what a window saw (no stack), its ``--json`` document's shape, and the
text tables rendered from their column lists."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np

from clients.report.build import Observations, build_run, simulator_settings
from clients.report.cli import json_document
from clients.report.quality import LAND, WATER
from clients.report.results import Machine, Run
from clients.report.sockets import SocketBytes
from clients.report.table import Column, fmt_ms, render_table, text_column
from clients.report.text import render_comparison, render_run

from .test_quality import box, header, obj
from .test_report_stats import MS, path_spans, stats_msg

# The document's keys, as scripts and docs/report.md read them.
RUN_KEYS = [
    "encoding",
    "duration_s",
    "hosts",
    "spans",
    "topics",
    "samples",
    "processes",
    "network",
    "bridge",
    "machine",
    "detection_quality",
    "profile",
    "water_model",
    "point_fields",
    "thesis_comparison",
]
TOPIC_KEYS = [
    "messages",
    "rate_hz",
    "period_ms",
    "payload_bytes",
    "wire_in_bytes",
    "wire_out_bytes",
    "payload_bytes_mean",
    "overhead_in",
    "overhead_out",
    "subscribers",
    "stages",
    "deadline_misses",
    "result_deadline_misses",
    "unprocessed",
    "thesis",
]
NETWORK_KEYS = [
    "payload_bytes_per_s",
    "wire_in_bytes_per_s",
    "loopback_bytes_per_s",
    "wire_over_payload",
    "loopback_over_payload",
    "sensor_payload_bytes_per_s",
    "sensor_wire_in_bytes_per_s",
    "sensor_wire_over_payload",
    "stack_bytes_per_s",
    "stack_over_sensor_payload",
    "loopback_over_sensor_payload",
    "stack_bytes_per_s_by_process",
    "report_connection_bytes_per_s",
    "thesis",
]
PROCESS_KEYS = [
    "samples",
    "cpu_percent_mean",
    "cpu_percent_max",
    "rss_bytes_max",
    "pid",
    "host",
    "messages_out",
    "messages_in",
    "bytes_out",
    "bytes_in",
    "dropped",
]
CLASS_KEYS = [
    "detections",
    "true_detections",
    "objects",
    "detected_objects",
    "precision",
    "recall",
]
LIDAR_KEYS = [
    "scans",
    "boxes",
    "on_water",
    "bank",
    "min_returns",
    "range_m",
    "margin_m",
    "water_band_m",
]
RADAR_KEYS = [
    "sweeps",
    "targets",
    "on_water",
    "bank",
    "on_land",
    "on_open_water",
    "open_water_cells",
    "open_water_detections",
    "open_water_false_alarm_rate",
    "configured_false_alarm_rate",
]
ROW_KEYS = [
    "run",
    "quantity",
    "topic",
    "statistic",
    "ours",
    "thesis",
    "relation",
    "unit",
    "source",
    "comparable",
    "note",
]


def observations() -> Observations:
    spans = [s for k in range(10) for s in path_spans(10**18 + k * 500 * MS)]
    spans += [s for k in range(10) for s in path_spans(10**18 + k * 20 * MS, topic="/imu/data")]
    stats = [
        stats_msg(sec, name, 10.0 * sec, 100 * sec, pid)
        for sec in (1, 2)
        for name, pid in (("bridge", 11), ("simulator", 12))
    ]
    truth = {
        "header": header(1),
        "water_z_m": -3.0,
        "objects": [obj(0, (20.0, 0.0, 0.0), (4.0, 4.0, 6.0), on_water=True)],
    }
    boxes = {"header": header(1), "boxes": [box((19.0, -1.0, 0.0), (21.0, 1.0, 2.0))]}
    source = np.full((4, 5), WATER, np.int32)
    source[1, 3], source[2, 2] = 7, LAND
    radar_truth = {
        "header": header(2),
        "num_beams": 4,
        "num_cells": 5,
        "cell_source": source.reshape(-1),
        "objects": [obj(7, (12.0, 0.0, 0.0), (2.0, 2.0, 2.0), dominant=1, on_water=True)],
    }
    detections = {
        "header": header(2),
        "false_alarm_rate": 0.1,
        "detections": [{"beam": 1, "cell": 3, "target": 0}],
        "targets": [{"peak_beam": 1, "peak_cell": 3}],
    }
    # the bridge (pid 11) sends 250 kB to the simulator (12) and 5 kB to the report (99)
    before = [
        SocketBytes((11,), "b:1", "s:1"),
        SocketBytes((12,), "s:1", "b:1"),
        SocketBytes((11,), "b:2", "r:1"),
        SocketBytes((99,), "r:1", "b:2"),
    ]
    after = [
        replace(before[0], bytes_sent=250_000),
        replace(before[1], bytes_sent=50_000),
        replace(before[2], bytes_sent=5_000),
        before[3],
    ]
    return Observations(
        encoding="cbor",
        duration_s=5.0,
        spans=spans,
        process_stats=stats,
        bridge_stats={"topics": {"/imu/data": {}}},
        judged={
            "lidar_truth": [truth],
            "boxes": [boxes],
            "radar_truth": [radar_truth],
            "radar": [detections],
        },
        sim_config={
            "data": json.dumps(
                {"profile": "thesis", "lidar": {"water_model": "specular", "point_fields": "xyz"}}
            )
        },
        samples={"/lidar/points": "10 points x 16 B"},
        loopback_bytes=44_000,
        sockets_before=before,
        sockets_after=after,
        report_pid=99,
        machine=Machine(2, (1.0, 2.0, 3.0)),
        profile="thesis",
    )


def test_a_run_is_built_from_its_window():
    run = build_run(observations())
    assert run.label == "thesis/cbor" and run.hosts == ("host",) and run.spans > 0
    assert (run.water_model, run.point_fields) == ("specular", "xyz")
    assert run.processes["bridge"].cpu_percent_max == 20.0
    assert run.network is not None
    assert run.network.stack_bytes_per_s == 60_000.0  # (250 + 50) kB over 5 s
    assert run.network.report_connection_bytes_per_s == 1_000.0  # counted apart
    quality = run.detection_quality
    assert quality.lidar is not None and quality.lidar.on_water.precision == 1.0
    assert quality.radar is not None and quality.radar.on_water.recall == 1.0
    assert run.thesis_comparison[0].ours == run.topics["/lidar/points"].stages["transport"].mean
    assert set(run.stage_values) == set(run.topics)


def test_the_json_document_keeps_its_shape():
    run = build_run(observations())
    document = json.loads(json.dumps(json_document([run, replace(run, encoding="json")])))
    assert list(document) == ["runs", "sensor_topics", "thesis_comparison", "replay"]
    first = document["runs"][0]
    assert list(first) == RUN_KEYS
    assert list(first["topics"]["/lidar/points"]) == TOPIC_KEYS
    assert list(first["topics"]["/lidar/points"]["stages"]["transport"]) == [
        "n",
        "mean",
        "p50",
        "p90",
        "p99",
        "max",
    ]
    thesis = first["topics"]["/lidar/points"]["thesis"]
    assert thesis["transport"] == 86.0 and thesis["sources"]["transport"] == "table A.1 5b"
    assert list(first["network"]) == NETWORK_KEYS
    assert list(first["network"]["thesis"]) == [
        "wire_bytes_per_s",
        "payload_bytes_per_s",
        "overhead",
    ]
    assert list(first["processes"]["bridge"]) == PROCESS_KEYS
    assert list(first["detection_quality"]["lidar"]) == LIDAR_KEYS
    assert list(first["detection_quality"]["radar"]) == RADAR_KEYS
    for sensor in ("lidar", "radar"):
        for where in ("on_water", "bank"):
            assert list(first["detection_quality"][sensor][where]) == CLASS_KEYS
    assert first["machine"] == {"cpus": 2, "load_average_1_5_15": [1.0, 2.0, 3.0]}
    rows = document["thesis_comparison"]
    assert {row["run"] for row in rows} == {"thesis/cbor", "thesis/json"}
    assert list(rows[0]) == [*ROW_KEYS, "context"]
    assert all(list(row)[: len(ROW_KEYS)] == ROW_KEYS for row in rows)


def test_nan_is_null_and_missing_quality_is_left_out():
    run = Run("cbor", 0.0)
    document = json_document([run])["runs"][0]
    assert document["detection_quality"] == {} and document["network"] is None
    assert "stage_values" not in document
    assert simulator_settings({"data": "[1, 2]"}, None) == ("unknown", "unknown", "unknown")
    assert simulator_settings(None, "default") == ("default", "unknown", "unknown")
    assert json_document([replace(run, duration_s=math.nan)])["runs"][0]["duration_s"] is None


def test_every_table_renders_from_its_columns():
    run = build_run(observations())
    text = render_run(run)
    for heading in (
        "rate Hz",
        "encoding ratio",
        "stage (ms)",
        "cpu % mean",
        "quantity",
        "thesis Ø 86 ms (table A.1 5b)",
        "detection quality, radar targets",
    ):
        assert heading in text
    comparison = render_comparison([run, replace(run, profile="default")])
    assert comparison.splitlines()[0].split()[2:4] == ["thesis/cbor", "cbor"]


def test_a_table_sizes_its_columns_and_aligns_numbers_right():
    rows = [("a", 1.0), ("longer name", 123.456)]
    columns = (text_column("name", lambda r: r[0]), Column("value", lambda r: r[1], fmt_ms, "ms"))
    assert render_table(columns, rows, indent="") == [
        "name         value ms",
        "a                1.00",
        "longer name    123.46",
    ]
