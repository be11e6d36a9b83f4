"""The dashboard in a real browser (Debian Chromium via playwright-core) against a real stack.

One scenario per module drives the page as an operator would (see drive_dashboard.mjs) while
this process publishes trace spans of a probe topic on /riverbridge/trace, exactly as the
components do; the tests then check what the page showed and did.
"""

from __future__ import annotations

import asyncio
import json
import math
import time
from pathlib import Path
from typing import Any

import pytest

from clients import RosbridgeClient

from .stack import REPO_ROOT, SCRIPTS_DIR, Stack

pytestmark = pytest.mark.slow

SCREENSHOT = REPO_ROOT / "artifacts" / "dashboard.png"
SCENARIO_TIMEOUT_S = 200.0
PROBE_TOPIC = "/dashboard_probe"
TRACE = ("/riverbridge/trace", "riverbridge_msgs/msg/TraceSpanArray")
# (stage, process, peer, start_ms, end_ms) after the probe message's capture time
PROBE_SPANS = (
    ("generate", "simulator", "", 0.0, 12.0),
    ("encode", "simulator", "", 12.0, 13.0),
    ("send", "simulator", "", 13.0, 14.0),
    ("bridge_in", "bridge", "", 15.0, 16.0),
    ("fanout", "bridge", "probe_reader", 16.0, 18.0),
    ("decode", "probe_reader", "", 19.0, 21.0),
    ("process", "probe_reader", "", 21.0, 31.0),
)


def probe_trace(stamp_ns: int) -> dict[str, Any]:
    spans = [
        {
            "topic": PROBE_TOPIC,
            "stamp_ns": stamp_ns,
            "stage": stage,
            "process": process,
            "peer": peer,
            "start_ns": stamp_ns + int(start_ms * 1e6),
            "end_ns": stamp_ns + int(end_ms * 1e6),
            "payload_bytes": 1000,
            "wire_bytes": 1100,
        }
        for stage, process, peer, start_ms, end_ms in PROBE_SPANS
    ]
    return {"host": "dashboard-test", "spans": spans}


async def publish_probe_traces(url: str, stop: asyncio.Event) -> int:
    async with RosbridgeClient(url, encoding="cbor", name="dashboard_probe") as client:
        await client.advertise(*TRACE)
        sent = 0
        while not stop.is_set():
            await client.publish(TRACE[0], probe_trace(time.time_ns()))
            sent += 1
            await asyncio.sleep(0.25)
        return sent


async def drive(stack: Stack, screenshot: Path) -> dict[str, Any]:
    stop = asyncio.Event()
    probe = asyncio.create_task(publish_probe_traces(stack.ws_url, stop))
    node = await asyncio.create_subprocess_exec(
        "node",
        str(SCRIPTS_DIR / "drive_dashboard.mjs"),
        stack.page_url,
        str(screenshot),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        out, err = await asyncio.wait_for(node.communicate(), SCENARIO_TIMEOUT_S)
    finally:
        stop.set()
        await probe
    lines = out.decode().strip().splitlines()
    assert lines, f"drive_dashboard.mjs printed nothing; stderr:\n{err.decode()}"
    result = json.loads(lines[-1])
    assert result["ok"], f"{result.get('reason')}\nstack log:\n{stack.log()[-4000:]}"
    return result


@pytest.fixture(scope="module")
def seen(stack: Stack) -> dict[str, Any]:
    SCREENSHOT.parent.mkdir(exist_ok=True)
    SCREENSHOT.unlink(missing_ok=True)
    return asyncio.run(drive(stack, SCREENSHOT))


def test_page_connects_and_receives_every_panels_topics(seen: dict[str, Any]) -> None:
    assert seen["connected"]
    for topic in (
        "/lidar/points",
        "/camera/image/compressed",
        "/radar/image",
        "/imu/data",
        "/odom",
        "/nav/boxes",
        "/nav/radar_detections",
        "/nav/lines",
        "/nav/obstacle_map",
    ):
        assert seen["counts"][topic] > 0, topic
    assert seen["page_errors"] == []


def test_every_canvas_panel_shows_live_data(seen: dict[str, Any]) -> None:
    # pixels differ between two moments seconds apart, and each panel drew more than its frame
    panels = ("map", "camera", "radar", "imu", "latency")
    assert seen["panels_changed"] == dict.fromkeys(panels, True)
    for panel in panels:
        assert seen["second"][panel]["lit"] > 500, panel


def test_radar_panel_draws_each_new_sweep(seen: dict[str, Any]) -> None:
    # the polar raster itself (not only its caption) differs after the vessel has turned
    assert seen["radar_raster_changed"]
    assert seen["second"]["radar_raster"]["lit"] > 500
    assert seen["delivery_second"]["radar_sweeps"] > seen["delivery_first"]["radar_sweeps"] > 0


def test_lidar_points_reach_the_map_through_the_worker(seen: dict[str, Any]) -> None:
    first, second = seen["delivery_first"], seen["delivery_second"]
    assert second["worker_connected"]
    assert second["worker_errors"] == []
    assert second["received"] > first["received"] > 0  # still arriving, scan after scan
    assert 1000 < second["map_points"] <= 40_000  # decimated in the worker
    assert second["map_has_points_bitmap"]  # plotted in the worker, drawn on the map
    # the page's own connection never subscribes to the 2.9 MB scan: only the worker does
    assert "/lidar/points" not in second["main_connection_topics"]
    assert "/radar/image" in second["main_connection_topics"]


def test_topic_list_names_topics_types_rates_and_clients(seen: dict[str, Any]) -> None:
    text = seen["topics_text"]
    for expected in (
        "/lidar/points",
        "sensor_msgs/msg/PointCloud2",
        "/nav/boxes",
        "riverbridge_msgs/msg/BoxArray",
        "/rosbridge_websocket",
    ):
        assert expected in text, expected
    clients = [line for line in text.splitlines() if line.startswith("/rosbridge_client_")]
    assert len(clients) >= 3, text  # simulator, navigation and the page itself
    imu_row = next(line for line in text.splitlines() if line.startswith("/imu/data"))
    assert float(imu_row.split("\t")[1]) > 5.0, imu_row
    # the catalogue's word on each of its topics, on hover; the whole stack is up
    assert "LIDAR scan, sensor frame · simulator · sensor" in seen["topics_titles"]
    assert "LIDAR obstacle boxes · navigation · output" in seen["topics_titles"]
    assert "expected, not published" not in text
    # each client's link from the bridge's /metrics (docs/bridge.md, "Over a thin link")
    assert "links (bridge /metrics)" in text and "RTT" in text, text


def test_restart_counts_of_up_are_shown(seen: dict[str, Any]) -> None:
    """`up` publishes its restart counts (latched /riverbridge/restarts); none happened."""
    lines = seen["topics_text"].splitlines()
    start = lines.index("restarts by riverbridge up")
    rows = [line.split("\t")[:2] for line in lines[start + 1 : start + 4]]
    assert rows == [["bridge", "0"], ["simulator", "0"], ["navigation", "0"]], lines[start:]


def test_latency_panel_joins_trace_spans_per_stage(seen: dict[str, Any]) -> None:
    probe = seen["trace"][PROBE_TOPIC]
    assert probe["generate"] == pytest.approx(12.0, abs=0.01)
    assert probe["process"] == pytest.approx(10.0, abs=0.01)
    assert probe["→bridge"] == pytest.approx(1.0, abs=0.01)  # bridge_in.start - send.end
    assert probe["→client"] == pytest.approx(1.0, abs=0.01)  # decode.start - fanout.end
    assert probe["end_to_end"] == pytest.approx(9.0, abs=0.01)  # decode.end - generate.end
    for topic in ("/imu/data", "/lidar/points"):
        assert 0.0 < seen["ages"][topic] < 5000.0, topic  # capture -> decoded in the page


def test_arrow_key_turns_the_vessel(seen: dict[str, Any]) -> None:
    assert seen["command_while_held"]["yaw_nm"] > 0  # left arrow: counter-clockwise moment
    turned_deg = math.degrees(seen["turned_rad"])  # followed every 100 ms, so unwrapped
    assert turned_deg > 5.0, f"heading changed by {turned_deg:.1f} deg"


def test_screenshot_is_saved(seen: dict[str, Any]) -> None:
    assert SCREENSHOT.stat().st_size > 50_000
    assert SCREENSHOT.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
