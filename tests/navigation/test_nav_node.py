"""The navigation edge against a real bridge on 127.0.0.1, port 0."""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import sys
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from clients import RosbridgeClient
from clients.tracing import Tracer
from navigation.cli import main
from navigation.config import NavigationConfig
from navigation.lidar_worker import ProcessLidarWorker, ThreadLidarWorker
from navigation.node import NavigationNode, serve
from navigation.processors import Processors
from schemas.pointcloud import pack_points
from tests.navigation.lidar_gate import GatedScan
from tests.navigation.nav_scenes import (
    camera_line_msg,
    default_scene,
    imu_msg,
    lidar_directions,
    radar_image_msg,
    raycast,
)

pytestmark = pytest.mark.slow
WAIT_S = 30.0


@pytest.fixture
async def bridge_url() -> AsyncIterator[str]:
    from bridge.compose import run_bridge
    from bridge.config import BridgeConfig

    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as running:
        yield running.url


@pytest.fixture
async def peer(bridge_url: str) -> AsyncIterator[RosbridgeClient]:
    """The other side: publishes sensor data, subscribes to the navigation outputs."""
    async with RosbridgeClient(bridge_url, encoding="cbor", connect_timeout=5.0) as client:
        for topic, type_name in INPUTS.items():
            await client.advertise(topic, type_name)
        yield client


INPUTS = {
    "/lidar/points": "sensor_msgs/msg/PointCloud2",
    "/radar/image": "riverbridge_msgs/msg/RadarImage",
    "/camera/image/compressed": "sensor_msgs/msg/CompressedImage",
    "/imu/data": "sensor_msgs/msg/Imu",
}


def scan_msg(stamp_ns: int) -> dict[str, Any]:
    points, _ = raycast(default_scene(), lidar_directions(0.25, 0.25))
    return pack_points(points, stamp_ns, "lidar")


def radar_msg(stamp_ns: int) -> dict[str, Any]:
    return radar_image_msg(stamp_ns, n_cells=800, range_step_m=0.25, target_cell=400)  # 100.125 m


def camera_msg(stamp_ns: int) -> dict[str, Any]:
    return camera_line_msg(stamp_ns, width_px=640, height_px=480)


async def first(sub, predicate=lambda msg: True) -> dict[str, Any]:
    async def find() -> dict[str, Any]:
        async for received in sub:
            if predicate(received.msg):
                return received.msg
        raise AssertionError("subscription ended")

    return await asyncio.wait_for(find(), WAIT_S)


async def wait_until(condition, what: str) -> None:
    async def poll() -> None:
        while not condition():
            await asyncio.sleep(0.02)

    try:
        await asyncio.wait_for(poll(), WAIT_S)
    except TimeoutError:
        raise AssertionError(f"timed out waiting for {what}") from None


async def until_subscribed(peer, topics: tuple[str, ...]) -> None:
    """Wait until the bridge lists a subscriber of every topic (rosapi), so a publish reaches
    the node: the condition itself, not a sleep."""

    async def listed(topic: str) -> bool:
        reply = await peer.call_service("/rosapi/subscribers", {"topic": topic})
        return bool(reply["subscribers"])

    async def poll() -> None:
        for topic in topics:
            while not await listed(topic):
                await asyncio.sleep(0.02)

    try:
        await asyncio.wait_for(poll(), WAIT_S)
    except TimeoutError:
        raise AssertionError(f"no subscriber of {topics} listed by the bridge") from None


SENSOR_INPUTS = ("/imu/data", "/lidar/points", "/radar/image", "/camera/image/compressed")


async def test_sensor_data_in_navigation_outputs_out(bridge_url, peer):
    stop = asyncio.Event()
    node_task = asyncio.create_task(serve(bridge_url, NavigationConfig(), stop))
    subs = {
        name: await peer.subscribe(f"/nav/{name}", type_name)
        for name, type_name in [
            ("boxes", "riverbridge_msgs/msg/BoxArray"),
            ("markers", "visualization_msgs/msg/MarkerArray"),
            ("radar_detections", "riverbridge_msgs/msg/RadarDetectionArray"),
            ("lines", "riverbridge_msgs/msg/ImageLineArray"),
            ("obstacle_map", "nav_msgs/msg/OccupancyGrid"),
            ("diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
        ]
    }
    try:
        await until_subscribed(peer, SENSOR_INPUTS)  # the node hears the first publish
        stamp = 1_000_000_000
        scan, radar, camera = scan_msg(stamp), radar_msg(stamp), camera_msg(stamp)
        for i in range(20):
            await peer.publish("/imu/data", imu_msg(stamp + i * 10_000_000))
        await peer.publish("/lidar/points", scan)
        await peer.publish("/radar/image", radar)
        await peer.publish("/camera/image/compressed", camera)

        boxes = await first(subs["boxes"])
        assert boxes["num_clusters"] == 8 and boxes["header"]["stamp"]["sec"] == 1
        markers = await first(subs["markers"])
        assert markers["markers"][0]["action"] == 3
        assert len(markers["markers"]) == len(boxes["boxes"]) + 1
        detections = await first(subs["radar_detections"])
        xy = np.array([[d["x_m"], d["y_m"]] for d in detections["detections"]])
        assert np.min(np.linalg.norm(xy - [0.0, 100.125], axis=1)) < 0.01
        lines = await first(subs["lines"])
        assert any(abs(line["theta_rad"] - np.pi / 2) < 0.02 for line in lines["lines"])
        grid = await first(subs["obstacle_map"], lambda m: (m["data"] == 100).sum() > 10)
        assert grid["info"]["width"] == 400 and grid["data"].dtype == np.int8
        diagnostics = await first(
            subs["diagnostics"], lambda m: m["status"][0]["message"] != "no message yet"
        )
        imu = {kv["key"]: kv["value"] for kv in diagnostics["status"][0]["values"]}
        assert float(imu["rate_hz"]) == pytest.approx(100.0, rel=0.01)
        assert imu["gaps"] == "0"
        subscribers = {
            topic: set(
                (await peer.call_service("/rosapi/subscribers", {"topic": topic}))["subscribers"]
            )
            for topic in ("/imu/data", "/lidar/points")
        }
        # The IMU has a connection of its own: it never waits on the wire behind a scan.
        assert len(subscribers["/imu/data"]) == len(subscribers["/lidar/points"]) == 1
        assert subscribers["/imu/data"] != subscribers["/lidar/points"]
    finally:
        stop.set()
        await asyncio.wait_for(node_task, WAIT_S)


@pytest.mark.parametrize("worker", [ProcessLidarWorker, ThreadLidarWorker])
async def test_slow_lidar_neither_delays_camera_and_imu_nor_queues_scans(
    bridge_url, peer, tmp_path, worker
):
    """The LIDAR step blocks where it really runs (the worker process, or the LIDAR thread)
    while the camera and the IMU go on and newer scans replace older ones."""
    config = NavigationConfig()
    entered, gate = tmp_path / "entered", tmp_path / "gate"
    lidar = worker(config.lidar, GatedScan(entered, gate, WAIT_S))
    processors = Processors(config, lidar_worker=lidar)
    stop, tracer = asyncio.Event(), Tracer("navigation")
    async with RosbridgeClient(bridge_url, connect_timeout=5.0, name="nav") as client:
        node = NavigationNode(client, config, processors, tracer=tracer)
        node_task = asyncio.create_task(node.run(stop))
        try:
            await wait_until(lambda: "imu" in node.subscriptions, "node subscriptions")
            await until_subscribed(peer, SENSOR_INPUTS)  # the bridge routes to the node
            scan = scan_msg(1)
            await peer.publish("/lidar/points", scan)
            await wait_until(entered.exists, "the LIDAR step to start")
            for _ in range(3):  # scans arriving while the first one is still processed
                await peer.publish("/lidar/points", scan)
            await peer.publish("/camera/image/compressed", camera_msg(2))
            for i in range(10):
                await peer.publish("/imu/data", imu_msg(i * 10_000_000))
            await wait_until(lambda: node.counters["camera"].processed == 1, "camera")
            await wait_until(lambda: node.imu.snapshot() is not None, "imu")
            await wait_until(lambda: node.imu.snapshot().stamp_stats.count == 10, "imu")
            await wait_until(lambda: node.subscriptions["lidar"].received == 4, "scans")
            assert node.counters["lidar"].processed == 0
            gate.touch()
            await wait_until(lambda: node.counters["lidar"].processed == 2, "newest scan")
            assert node.counters["lidar"].skipped == 2
            # the pipeline's step timings, returned from the worker, reach the trace
            stages = {
                s["stage"] for s in tracer.batch_msg()["spans"] if s["topic"] == "/lidar/points"
            }
            assert {"process", "process.filter", "process.dbscan", "process.boxes"} <= stages
        finally:
            gate.touch()
            stop.set()
            await asyncio.wait_for(node_task, WAIT_S)


def test_cli_names_a_bad_config(tmp_path, caplog):
    path = tmp_path / "nav.toml"
    path.write_text("[lidar]\nepsilon = 1\n")
    assert main(["--bridge", "ws://127.0.0.1:9", "--config", str(path)]) == 2
    assert "epsilon" in caplog.text


async def test_cli_runs_for_a_duration_and_reports_an_unreachable_bridge(bridge_url):
    quiet = ["--log-level", "CRITICAL"]
    assert await asyncio.to_thread(main, ["--bridge", bridge_url, "--duration", "1.0", *quiet]) == 0
    unreachable = ["--bridge", "ws://127.0.0.1:9", "--connect-timeout", "0.3", *quiet]
    assert await asyncio.to_thread(main, unreachable) == 1


def descendants(pid: int) -> set[int]:
    """Process ids below ``pid`` (Linux /proc), children first."""
    found: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        with contextlib.suppress(OSError):
            for child in map(int, (task / "children").read_text().split()):
                found |= {child} | descendants(child)
    return found


def alive(pid: int) -> bool:
    """Running or sleeping, not gone and not a zombie waiting for its parent."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize(
    ("stop_signal", "to_group", "exit_code"),
    [
        (signal.SIGTERM, False, 0),  # docker stop, the supervisor
        (signal.SIGINT, True, 0),  # Ctrl-C: the terminal signals the whole process group
        (signal.SIGKILL, False, -signal.SIGKILL),  # no clean-up at all in the parent
    ],
)
async def test_python_m_navigation_leaves_no_worker_process_behind(
    bridge_url, peer, stop_signal, to_group, exit_code
):
    """`python -m navigation` exits 0 on SIGTERM and Ctrl-C; whichever way it ends, its
    LIDAR worker process ends too."""
    diagnostics = await peer.subscribe("/nav/diagnostics", "diagnostic_msgs/msg/DiagnosticArray")
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "navigation",
        "--bridge",
        bridge_url,
        "--log-level",
        "WARNING",
        start_new_session=True,
    )
    workers: set[int] = set()
    try:
        msg = await first(diagnostics)
        names = [status["name"] for status in msg["status"]]
        assert names == [
            "navigation/imu",
            "navigation/lidar",
            "navigation/radar",
            "navigation/camera",
        ]
        await wait_until(lambda: descendants(process.pid), "the LIDAR worker process")
        workers = descendants(process.pid)
    finally:
        if to_group:
            os.killpg(process.pid, stop_signal)
        else:
            process.send_signal(stop_signal)
        assert await asyncio.wait_for(process.wait(), WAIT_S) == exit_code
        await wait_until(lambda: not any(map(alive, workers)), "the worker processes to exit")
