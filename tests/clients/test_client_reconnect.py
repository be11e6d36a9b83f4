"""The bridge starts late or restarts: clients connect, resume and carry on by themselves."""

from __future__ import annotations

import asyncio
from urllib.parse import urlsplit

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import ClientClosed, RosbridgeClient
from tests.clients.client_messages import publish_until_received

ADD = "example_interfaces/srv/AddTwoInts"


async def add_two_ints(args: dict) -> dict:
    return {"sum": args["a"] + args["b"]}


def port_of(url: str) -> int:
    return urlsplit(url).port


async def call_when_available(
    client: RosbridgeClient, service: str, args: dict, timeout_s: float = 10.0
) -> dict:
    """Retry a call until the (re-)advertised service answers."""
    async with asyncio.timeout(timeout_s):
        while True:
            try:
                return await client.call_service(service, args, timeout=1.0)
            except Exception:  # not yet re-advertised or not yet reconnected
                await asyncio.sleep(0.05)


@pytest.mark.parametrize("encoding", ["json", "cbor"])
async def test_bridge_restart_on_same_port_resumes_everything(make_client, registry, encoding):
    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as first:
        url = first.url
        sim = await make_client(url, encoding=encoding, name="sim", backoff_max=0.5)
        nav = await make_client(url, encoding=encoding, name="nav", backoff_max=0.5)
        await sim.advertise("/status", "std_msgs/msg/String")
        await sim.advertise_service("/add", ADD, add_two_ints)
        sub = await nav.subscribe("/status", "std_msgs/msg/String")
        got = await publish_until_received(sim, "/status", {"data": "before"}, sub)
        assert got.msg == {"data": "before"}
        assert await call_when_available(nav, "/add", {"a": 1, "b": 2}) == {"sum": 3}

    async with asyncio.timeout(5):
        while sim.is_connected or nav.is_connected:
            await asyncio.sleep(0.01)
    await sim.publish("/status", {"data": "lost while down"})
    assert sim.publish_stats("/status").dropped_disconnected >= 1

    async with run_bridge(BridgeConfig(host="127.0.0.1", port=port_of(url))):
        await asyncio.gather(sim.wait_connected(10), nav.wait_connected(10))
        assert sim.connections == 2 and nav.connections == 2
        while sub.get_nowait() is not None:
            pass
        got = await publish_until_received(sim, "/status", {"data": "after"}, sub)
        assert got.msg == {"data": "after"}
        assert await call_when_available(nav, "/add", {"a": 20, "b": 22}) == {"sum": 42}


async def test_client_started_before_the_bridge(unused_tcp_port, make_client):
    url = f"ws://127.0.0.1:{unused_tcp_port}"
    early = RosbridgeClient(url, connect_timeout=10.0, backoff_max=0.2)
    connecting = asyncio.create_task(early.connect())
    await asyncio.sleep(0.5)
    assert not connecting.done()
    async with run_bridge(BridgeConfig(host="127.0.0.1", port=unused_tcp_port)):
        await asyncio.wait_for(connecting, 10)
        other = await make_client(url)
        await early.advertise("/hello", "std_msgs/msg/String")
        sub = await other.subscribe("/hello", "std_msgs/msg/String")
        got = await publish_until_received(early, "/hello", {"data": "hi"}, sub)
        assert got.msg == {"data": "hi"}
        await early.close()


async def test_close_ends_subscriptions_and_rejects_use(make_client, bridge):
    client = await make_client(bridge.url)
    sub = await client.subscribe("/t", "std_msgs/msg/String")
    consumer = asyncio.create_task(anext(sub, None))
    await asyncio.sleep(0.05)
    await client.close()
    assert await asyncio.wait_for(consumer, 2) is None
    with pytest.raises(ClientClosed):
        await client.connect()
    with pytest.raises(ClientClosed):
        await client.publish("/t", {"data": "x"})
