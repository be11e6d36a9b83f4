"""The simulator edge against a real bridge on 127.0.0.1 port 0: topics, types, commands, CLI."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.catalogue import published_by
from simulator.cli import main
from simulator.config import CameraConfig, LidarConfig, SceneConfig, SimConfig
from simulator.node import serve
from simulator.scene import build_scene
from tests.receiving import collect

pytestmark = pytest.mark.slow

# What the simulator streams, and more (schemas.catalogue): key -> (name, type)
TOPICS = {t.key: t.pair for t in published_by("simulator", "sensor", "realtime")}
TF_STATIC, GROUND_TRUTH = CATALOGUE["tf_static"].pair, CATALOGUE["ground_truth"].pair
COMMAND = CATALOGUE["cmd_wrench"].pair
TRUTH_TOPICS = {"lidar": CATALOGUE["lidar_truth"].pair, "radar": CATALOGUE["radar_truth"].pair}

# A light configuration: coarse terrain and a 2-degree LIDAR keep the test fast on 2 cores.
LIGHT = SimConfig(
    scene=SceneConfig(terrain_cells=80, trees=10, houses=3),
    lidar=LidarConfig(horizontal_resolution_deg=2.0, vertical_resolution_deg=2.0, rate_hz=4.0),
    camera=CameraConfig(width_px=160, height_px=120, rate_hz=4.0),
)


@pytest.fixture
async def bridge():
    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as running:
        yield running


@pytest.mark.parametrize("encoding", ["cbor", "json"])
async def test_every_topic_arrives_typed_and_stamped(bridge, registry, encoding):
    scene = await asyncio.to_thread(build_scene, LIGHT.scene, seed=LIGHT.seed)
    stop = asyncio.Event()
    async with RosbridgeClient(bridge.url, encoding=encoding, registry=registry) as listener:
        subs = {
            name: await listener.subscribe(topic, type_name, maxsize=100)
            for name, (topic, type_name) in TOPICS.items()
        }
        static = await listener.subscribe(*TF_STATIC)
        truth = {
            name: await listener.subscribe(*topic, maxsize=10)
            for name, topic in TRUTH_TOPICS.items()
        }
        sim = asyncio.create_task(serve(bridge.url, LIGHT, stop, encoding=encoding, scene=scene))
        try:
            imu = await collect(subs["imu"], 20, timeout_s=10.0)
            others = {
                name: await collect(subs[name], 1, timeout_s=10.0)
                for name in ("lidar", "radar", "camera", "gnss", "odom", "tf")
            }
            tf_static = await collect(static, 1, timeout_s=5.0)
            truths = {name: await collect(sub, 1, timeout_s=5.0) for name, sub in truth.items()}
            # latched: a late subscriber still gets the scene's objects
            markers = await collect(await listener.subscribe(*GROUND_TRUTH), 1, timeout_s=5.0)
            publishers = {
                topic: (await listener.call_service("/rosapi/publishers", {"topic": topic}))[
                    "publishers"
                ]
                for topic in (TOPICS["lidar"][0], TOPICS["imu"][0], TOPICS["odom"][0])
            }
        finally:
            stop.set()
            await sim
    # The small, frequent messages have a connection of their own (never behind a scan).
    assert publishers[TOPICS["imu"][0]] == publishers[TOPICS["odom"][0]]
    assert len(publishers[TOPICS["imu"][0]]) == len(publishers[TOPICS["lidar"][0]]) == 1
    assert publishers[TOPICS["imu"][0]] != publishers[TOPICS["lidar"][0]]
    assert len(imu) == 20
    assert imu[-1]["linear_acceleration"]["z"] == pytest.approx(9.80665, abs=1e-6)
    stamps = [m["header"]["stamp"]["sec"] * 10**9 + m["header"]["stamp"]["nanosec"] for m in imu]
    assert np.all(np.diff(stamps) > 0)
    assert all(others[name] for name in others), {k: len(v) for k, v in others.items()}
    cloud = others["lidar"][0]
    assert cloud["header"]["frame_id"] == "lidar" and cloud["point_step"] == 16
    assert len(cloud["data"]) == cloud["row_step"] == 16 * cloud["width"] > 0
    assert others["radar"][0]["reflectance"].dtype == np.float32
    assert others["camera"][0]["data"][:2] == b"\xff\xd8"  # JPEG start-of-image
    assert 51.0 < others["gnss"][0]["latitude"] < 52.0
    frames = {t["child_frame_id"] for t in tf_static[0]["transforms"]}
    assert frames == {"lidar", "radar", "camera_optical", "imu", "gnss"}
    assert len(markers[0]["markers"]) == len(scene.objects) > 0
    lidar_truth, radar_truth = truths["lidar"][0], truths["radar"][0]
    assert lidar_truth["header"]["frame_id"] == "lidar" and lidar_truth["sensor"] == "lidar"
    assert radar_truth["cell_source"].size == others["radar"][0]["reflectance"].size


async def test_wrench_command_drives_the_vessel(bridge, registry):
    scene = await asyncio.to_thread(build_scene, LIGHT.scene, seed=LIGHT.seed)
    stop = asyncio.Event()
    async with RosbridgeClient(bridge.url, registry=registry) as pilot:
        odom = await pilot.subscribe(TOPICS["odom"][0], TOPICS["odom"][1], maxsize=1)
        await pilot.advertise(*COMMAND)
        sim = asyncio.create_task(serve(bridge.url, LIGHT, stop, scene=scene))
        try:
            assert await collect(odom, 1, timeout_s=10.0)
            wrench = {
                "force": {"x": 3000.0, "y": 0.0, "z": 0.0},
                "torque": {"x": 0.0, "y": 0.0, "z": 0.0},
            }
            speed = 0.0
            async with asyncio.timeout(10.0):
                while speed < 0.5:
                    await pilot.publish(COMMAND[0], wrench)
                    (latest,) = await collect(odom, 1, timeout_s=1.0) or [None]
                    if latest is not None:
                        speed = latest["twist"]["twist"]["linear"]["x"]
        finally:
            stop.set()
            await sim
    assert speed >= 0.5


async def test_cli_runs_for_a_duration_and_reports_an_unreachable_bridge(bridge, tmp_path):
    config = tmp_path / "sim.toml"
    config.write_text(
        "[scene]\nterrain_cells = 40\ntrees = 0\nhouses = 0\n"
        "[lidar]\nhorizontal_resolution_deg = 4.0\nvertical_resolution_deg = 4.0\n"
    )
    code = await asyncio.to_thread(
        main,
        [
            "--bridge",
            bridge.url,
            "--config",
            str(config),
            "--duration",
            "1.0",
            "--log-level",
            "WARNING",
        ],
    )
    assert code == 0
    bad = tmp_path / "bad.toml"
    bad.write_text("[lidar]\nrange_maximum = 3\n")
    assert await asyncio.to_thread(main, ["--config", str(bad)]) == 2
    unreachable = [
        "--bridge",
        "ws://127.0.0.1:9",
        "--config",
        str(config),
        "--connect-timeout",
        "0.3",
        "--log-level",
        "CRITICAL",
    ]
    assert await asyncio.to_thread(main, unreachable) == 1
