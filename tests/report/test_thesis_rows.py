"""thesis_comparison: each row names the thesis's statistic and source, and ours is the same
statistic of the same quantity (docs/report.md)."""

from __future__ import annotations

import pytest

from clients.report.results import json_ready
from clients.report.sockets import SocketTraffic
from clients.report.stats import network_summary, summarise
from clients.report.thesis import FIGURES, STATISTICS, Measured, thesis_comparison

from .test_report_stats import MS, path_spans

SOURCES = ("table A.1", "table 4.9", "table 4.10", "tables 4.10 / 4.9", "4.3, figure 4.4")


def a_run() -> Measured:
    spans = [s for k in range(10) for s in path_spans(10**18 + k * 500 * MS)]
    topics = summarise(spans, 5.0)
    sockets = SocketTraffic(
        stack_bytes=100_000, instrument_bytes=0, by_process={"bridge": 100_000}, sockets=2
    )
    return Measured(topics, network_summary(topics, None, 5.0, sockets))


def test_every_row_names_a_known_statistic_and_a_thesis_source():
    rows = thesis_comparison(a_run())
    assert len(rows) == len(FIGURES)
    for row in rows:
        assert set(json_ready(row)) >= {
            "quantity",
            "topic",
            "statistic",
            "ours",
            "thesis",
            "source",
        }
        assert row.statistic in STATISTICS
        assert row.source.startswith(SOURCES), row.source
        assert row.relation in ("=", "<", ">", "~")
        assert row.comparable or row.note, "a row that does not compare says why"


def test_ours_is_the_same_statistic_of_the_same_stage():
    run = a_run()
    rows = {(r.quantity, r.topic, r.statistic): r for r in thesis_comparison(run)}
    stages = run.topics["/lidar/points"].stages
    transport = stages["transport"]
    row = rows[("transport", "/lidar/points", "mean")]
    assert (row.ours, row.thesis, row.source) == (
        pytest.approx(transport.mean),
        86.0,
        "table A.1 5b",
    )
    assert row.context is not None and row.context.p99 == pytest.approx(transport.p99)
    spread = rows[("transport", "/lidar/points", "max-p50")]
    assert spread.ours == pytest.approx(transport.max - transport.p50)
    assert spread.relation == "~" and spread.thesis == 50.0
    # table A.1's Sum column adds means: ours adds the simulator's stage means
    side = rows[("simulator per message", "/lidar/points", "mean")]
    assert side.ours == pytest.approx(
        sum(stages[s].mean for s in ("generate", "publish_wait", "encode", "send"))
    )
    assert rows[("payload per message", "/lidar/points", "mean")].ours == 1000.0
    overhead = rows[("network overhead", "", "ratio")]
    assert overhead.thesis == pytest.approx(5.562, abs=1e-3)  # 1.62 MB/s / 291.27 KB/s
    assert run.network is not None
    assert overhead.ours == pytest.approx(run.network.stack_over_sensor_payload)


def test_the_thesis_figures_are_the_thesis_s():
    figures = {(f.quantity, f.topic, f.statistic): f for f in FIGURES}
    expected = {  # appendix A (Ø), table 4.9 (Ø100), figure 4.4's text
        ("transport", "/lidar/points", "mean"): (86.0, "table A.1 5b"),
        ("transport", "/radar/image", "mean"): (30.0, "table A.1 5a"),
        ("transport", "/imu/data", "mean"): (9.0, "table A.1 5c"),
        ("transport", "/camera/image/compressed", "mean"): (6.0, "table A.1 5d"),
        ("DBSCAN", "/lidar/points", "mean"): (29.0, "table A.1 3f"),
        ("bounding boxes", "/lidar/points", "mean"): (186.0, "table A.1 3g"),
        ("payload per message", "/lidar/points", "mean"): (285_370.0, "table 4.9 5b"),
        ("payload per message", "/radar/image", "mean"): (5_780.0, "table 4.9 5a"),
    }
    for key, (value, source) in expected.items():
        assert (figures[key].thesis, figures[key].source) == (value, source)


@pytest.mark.parametrize("quantity", ["transport", "payload per message"])
def test_the_image_rows_say_they_do_not_compare(quantity):
    row = next(
        r
        for r in thesis_comparison(a_run())
        if r.quantity == quantity and r.topic == "/camera/image/compressed"
    )
    assert not row.comparable and "file path" in row.note


def test_a_missing_quantity_is_none_not_zero():
    row = next(r for r in thesis_comparison(Measured({})) if r.quantity == "transport")
    assert row.ours is None
    assert json_ready(row)["context"] == {"n": None, "p50": None, "p99": None, "max": None}
