"""`--dds --zenoh`: a gateway between a DDS domain and the Zenoh graph, nobody else's.

Bridge A is on both (DDS domain + Zenoh); bridge B only on DDS, standing in for a ROS 2 node
there; the Zenoh side is the independent participant (tests/zenoh/zenoh_peer.py). Messages
cross each way exactly once, in order, and never come back; a service a client of B provides
on DDS is called from Zenoh through A, and one the Zenoh participant provides from B.
"""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from clients.errors import ServiceError
from tests.graph_peers import RecordingService
from tests.receiving import drain
from tests.zenoh.conftest import run_peer

pytestmark = pytest.mark.slow


async def test_dds_and_zenoh_exchange_messages_once_and_a_service(
    zenoh_domain, zenoh_endpoint, registry
):
    gateway = BridgeConfig(
        host="127.0.0.1",
        port=0,
        dds=True,
        zenoh=True,
        dds_domain=zenoh_domain,
        zenoh_listen=(zenoh_endpoint,),
    )
    dds_only = BridgeConfig(host="127.0.0.1", port=0, dds=True, dds_domain=zenoh_domain)
    gate = RecordingService({"success": True, "message": "gate via DDS"})
    async with (
        run_bridge(gateway) as a,
        run_bridge(dds_only) as b,
        RosbridgeClient(a.url, registry=registry) as on_a,
        RosbridgeClient(b.url, registry=registry) as on_b,
    ):
        await on_b.advertise_service("/lock_gate", "std_srvs/srv/SetBool", gate)
        await on_b.advertise("/chatter", "std_msgs/msg/String")
        wrenches = await on_b.subscribe("/cmd_wrench", "geometry_msgs/msg/Wrench", maxsize=1000)
        heard_a = await on_a.subscribe("/chatter", "std_msgs/msg/String", maxsize=1000)

        async def talk() -> None:  # DDS side: numbered messages until cancelled
            for n in range(100_000):
                await on_b.publish("/chatter", {"data": str(n)})
                await asyncio.sleep(0.05)

        talking = asyncio.create_task(talk())
        steering = asyncio.create_task(run_peer(zenoh_endpoint, zenoh_domain, "wrench", "60", "10"))
        serving = asyncio.create_task(
            run_peer(zenoh_endpoint, zenoh_domain, "serve", "/zgate", "60")
        )
        try:
            taken = await run_peer(zenoh_endpoint, zenoh_domain, "take", "/chatter", "20", "60")
            forces = await numbered_forces(wrenches, count=20, timeout_s=60.0)
            called = await run_peer(zenoh_endpoint, zenoh_domain, "call", "/lock_gate", "30")

            async def across() -> dict | None:  # Zenoh server -> A -> DDS -> B's client
                try:
                    return await on_b.call_service("/zgate", {"data": True}, timeout=2.0)
                except (ServiceError, TimeoutError):  # not discovered yet on B
                    await asyncio.sleep(0.2)
                    return None

            async with asyncio.timeout(30):
                while (answer := await across()) is None:
                    pass
        finally:
            for task in (talking, steering, serving):
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        seen_on_a = [m["data"] for m in await drain(heard_a, 0.3)]
    numbers = [int(d) for d in taken["data"]]
    assert len(numbers) == 20
    assert numbers == list(range(numbers[0], numbers[0] + 20))  # once each, in order
    assert forces == list(range(forces[0], forces[0] + 20))  # Zenoh -> DDS: once, in order
    assert len(seen_on_a) >= 20 and len(seen_on_a) == len(set(seen_on_a))  # no echo
    assert called["success"] is True and called["message"] == "gate via DDS", called
    assert gate.requests == [{"data": True}]
    assert answer == {"success": True, "message": "zenoh says True"}


async def numbered_forces(subscription, count: int, timeout_s: float) -> list[int]:
    """The first `count` commands' numbers (force.y) as B's client receives them."""
    numbers: list[int] = []
    async with asyncio.timeout(timeout_s):
        async for item in subscription:
            numbers.append(int(item.msg["force"]["y"]))
            if len(numbers) == count:
                return numbers
    return numbers
