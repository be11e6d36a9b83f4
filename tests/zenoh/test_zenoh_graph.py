"""The Zenoh graph seen from a websocket client: a service a Zenoh node provides (listed by
rosapi, callable, gone with its token), a latched topic a late Zenoh subscriber still gets,
and Humble's keys (TypeHashNotSupported) when the bridge is told `--zenoh-distro humble`."""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from tests.zenoh.conftest import run_peer

pytestmark = pytest.mark.slow


def zenoh_config(domain: int, endpoint: str, distro: str = "jazzy") -> BridgeConfig:
    return BridgeConfig(
        host="127.0.0.1",
        port=0,
        zenoh=True,
        dds_domain=domain,
        zenoh_listen=(endpoint,),
        zenoh_distro=distro,  # type: ignore[arg-type]
    )


async def until(predicate, timeout_s: float = 20.0, every_s: float = 0.1):
    """Poll an async predicate until it returns something truthy; returns that."""
    async with asyncio.timeout(timeout_s):
        while not (result := await predicate()):
            await asyncio.sleep(every_s)
    return result


async def test_a_client_calls_a_service_a_zenoh_node_provides(
    zenoh_domain, zenoh_endpoint, registry
):
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        server = asyncio.create_task(
            run_peer(zenoh_endpoint, zenoh_domain, "serve", "/zgate", "60")
        )
        try:

            async def listed() -> bool:
                return "/zgate" in (await client.call_service("/rosapi/services"))["services"]

            await until(listed)
            node = await client.call_service("/rosapi/service_node", {"service": "/zgate"})
            answer = await client.call_service("/zgate", {"data": True})
            refused = await client.call_service("/zgate", {"data": False})
        finally:
            server.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await server

        async def gone() -> bool:  # the server's tokens went with its process
            return "/zgate" not in (await client.call_service("/rosapi/services"))["services"]

        await until(gone)
    assert node["node"] == "/zenoh_gatekeeper"
    assert answer == {"success": True, "message": "zenoh says True"}
    assert refused == {"success": False, "message": "zenoh says False"}


async def test_a_late_zenoh_subscriber_gets_a_latched_message(
    zenoh_domain, zenoh_endpoint, registry
):
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        await client.advertise("/harbour_map", "std_msgs/msg/String", latch=True)
        await client.publish("/harbour_map", {"data": "charted"})
        result = await run_peer(zenoh_endpoint, zenoh_domain, "latched", "/harbour_map", "20")
    assert result["data"] == "charted"


async def test_humble_keys_carry_no_type_hash(zenoh_domain, zenoh_endpoint, registry):
    async with (
        run_bridge(zenoh_config(zenoh_domain, zenoh_endpoint, "humble")) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as client,
    ):
        await client.advertise("/chatter", "std_msgs/msg/String")

        async def talk() -> None:
            for n in range(100_000):
                await client.publish("/chatter", {"data": f"humble {n}"})
                await asyncio.sleep(0.05)

        talking = asyncio.create_task(talk())
        try:
            taken = await run_peer(
                zenoh_endpoint, zenoh_domain, "take", "/chatter", "3", "30", distro="humble"
            )
            tokens = await run_peer(
                zenoh_endpoint, zenoh_domain, "tokens", "riverbridge_", "20", distro="humble"
            )
        finally:
            talking.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await talking
    assert len(taken["data"]) == 3 and all(d.startswith("humble ") for d in taken["data"])
    publisher = [t for t in tokens["tokens"] if "/MP/" in t and "%chatter" in t]
    assert publisher and publisher[0].split("/")[11] == "TypeHashNotSupported"
