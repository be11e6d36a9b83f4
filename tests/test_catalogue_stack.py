"""The catalogue is what the running simulator and navigation really do, as a real bridge sees
it: rosapi's nodes, node_details, publishers and topic_type against schemas.catalogue."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from navigation.config import LidarConfig as NavLidarConfig
from navigation.config import NavigationConfig
from navigation.node import serve as serve_navigation
from schemas.catalogue import consumed_by, published_by
from simulator.config import CameraConfig, LidarConfig, SceneConfig, SimConfig
from simulator.node import serve as serve_simulator
from simulator.scene import build_scene

pytestmark = pytest.mark.slow

# Light: a coarse scene and sensors; every topic is advertised all the same.
SIM = SimConfig(
    scene=SceneConfig(terrain_cells=40, trees=4, houses=2),
    lidar=LidarConfig(horizontal_resolution_deg=4.0, vertical_resolution_deg=4.0),
    camera=CameraConfig(width_px=80, height_px=60),
)
NAV = NavigationConfig(lidar=NavLidarConfig(worker="thread"))
TIMEOUT_S = 30.0
TELEMETRY = {t.name for t in published_by("every process")}


async def rosapi(client: RosbridgeClient, service: str, **args: Any) -> dict[str, Any]:
    return await client.call_service(f"/rosapi/{service}", args)


async def node_names(client: RosbridgeClient) -> set[str]:
    return set((await rosapi(client, "nodes"))["nodes"])


async def until_listed(client: RosbridgeClient, names: set[str]) -> None:
    async with asyncio.timeout(TIMEOUT_S):
        while not names <= set((await rosapi(client, "topics"))["topics"]):
            await asyncio.sleep(0.1)


async def graph_of(client: RosbridgeClient, nodes: set[str]) -> tuple[set[str], set[str]]:
    """What ``nodes`` (one process's connections) publish and subscribe to, together."""
    publishing: set[str] = set()
    subscribing: set[str] = set()
    for node in nodes:
        details = await rosapi(client, "node_details", node=node)
        publishing |= set(details["publishing"])
        subscribing |= set(details["subscribing"])
    return publishing, subscribing


async def observe_stack() -> dict[str, Any]:
    """Start the simulator, then navigation, against one bridge; tell their nodes apart by
    when they appeared; read what each publishes and subscribes to, and every topic's type
    and publishers."""
    scene = await asyncio.to_thread(build_scene, SIM.scene, seed=SIM.seed)
    stop = asyncio.Event()
    async with (
        run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as bridge,
        RosbridgeClient(bridge.url, name="judge") as judge,
    ):
        before = await node_names(judge)
        tasks = [asyncio.create_task(serve_simulator(bridge.url, SIM, stop, scene=scene))]
        try:
            await until_listed(judge, {t.name for t in published_by("simulator")})
            sim_nodes = await node_names(judge) - before
            tasks.append(asyncio.create_task(serve_navigation(bridge.url, NAV, stop)))
            await until_listed(judge, {t.name for t in published_by("navigation")})
            nav_nodes = await node_names(judge) - before - sim_nodes
            observed = {
                "simulator": await graph_of(judge, sim_nodes),
                "navigation": await graph_of(judge, nav_nodes),
                "nodes": {"simulator": sim_nodes, "navigation": nav_nodes},
            }
            names = {t.name for p in ("simulator", "navigation") for t in published_by(p)}
            observed["types"] = {
                name: (await rosapi(judge, "topic_type", topic=name))["type"] for name in names
            }
            observed["publishers"] = {
                name: set((await rosapi(judge, "publishers", topic=name))["publishers"])
                for name in names
            }
        finally:
            stop.set()
            await asyncio.gather(*tasks)
    return observed


@pytest.fixture(scope="module")
def observed() -> dict[str, Any]:
    return asyncio.run(observe_stack())


@pytest.mark.parametrize("process", ["simulator", "navigation"])
def test_each_process_publishes_and_reads_what_the_catalogue_says(observed, process):
    publishing, subscribing = observed[process]
    assert publishing == {t.name for t in published_by(process)} | TELEMETRY
    assert subscribing == {t.name for t in consumed_by(process)}


def test_every_topic_has_the_catalogues_type_and_only_its_producers_publishers(observed):
    for process in ("simulator", "navigation"):
        for topic in published_by(process):
            assert observed["types"][topic.name] == topic.type, topic.name
            publishers = observed["publishers"][topic.name]
            assert publishers and publishers <= observed["nodes"][process], topic.name
