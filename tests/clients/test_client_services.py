"""Service calls both ways through a real bridge: success, failure, timeout, dropped link."""

from __future__ import annotations

import asyncio
import time

import pytest

from clients import ConnectionClosed, ServiceError

ADD = "example_interfaces/srv/AddTwoInts"


async def add_two_ints(args: dict) -> dict:
    return {"sum": args["a"] + args["b"]}


async def wait_for_service(client, service: str, timeout_s: float = 5.0) -> None:
    """Poll rosapi until ``service`` is listed (advertise_service has no acknowledgement)."""
    async with asyncio.timeout(timeout_s):
        while service not in (await client.call_service("/rosapi/services"))["services"]:
            await asyncio.sleep(0.02)


@pytest.mark.parametrize("encoding", ["json", "cbor"])
async def test_client_provides_and_client_calls(bridge, make_client, encoding):
    provider = await make_client(bridge.url, encoding=encoding, name="provider")
    caller = await make_client(bridge.url, encoding=encoding, name="caller")
    await provider.advertise_service("/add", ADD, add_two_ints)
    await wait_for_service(caller, "/add")
    assert await caller.call_service("/add", {"a": 2, "b": 40}, type=ADD) == {"sum": 42}
    results = await asyncio.gather(
        *(caller.call_service("/add", {"a": i, "b": i}) for i in range(10))
    )
    assert [r["sum"] for r in results] == [2 * i for i in range(10)]


async def test_handler_receives_normalized_args(bridge, make_client):
    seen = []

    async def handler(args: dict) -> dict:
        seen.append(args)
        return {"success": True, "message": "ok"}

    provider = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await provider.advertise_service("/toggle", "std_srvs/srv/SetBool", handler)
    await wait_for_service(caller, "/toggle")
    assert await caller.call_service("/toggle", {"data": True}) == {
        "success": True,
        "message": "ok",
    }
    assert seen == [{"data": True}]


async def test_bridge_service_rosapi(bridge, make_client):
    client = await make_client(bridge.url, encoding="json")
    publisher = await make_client(bridge.url)
    await publisher.advertise("/listed", "std_msgs/msg/String")
    async with asyncio.timeout(5):
        while "/listed" not in (topics := await client.call_service("/rosapi/topics"))["topics"]:
            await asyncio.sleep(0.02)
    assert "/rosout" in topics["topics"]


async def test_handler_exception_is_a_service_error(bridge, make_client):
    async def broken(args: dict) -> dict:
        raise ValueError("cannot add these")

    provider = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await provider.advertise_service("/broken", ADD, broken)
    await wait_for_service(caller, "/broken")
    with pytest.raises(ServiceError, match="cannot add these") as info:
        await caller.call_service("/broken", {"a": 1, "b": 2})
    assert info.value.service == "/broken"


async def test_missing_service_fails_promptly(bridge, make_client):
    caller = await make_client(bridge.url)
    with pytest.raises(ServiceError):
        await caller.call_service("/does_not_exist", {}, timeout=5.0)


async def test_slow_service_times_out(bridge, make_client):
    async def slow(args: dict) -> dict:
        await asyncio.sleep(5)
        return {"sum": 0}

    provider = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await provider.advertise_service("/slow", ADD, slow)
    await wait_for_service(caller, "/slow")
    with pytest.raises(TimeoutError):
        await caller.call_service("/slow", {"a": 1, "b": 1}, timeout=0.3)
    await provider.unadvertise_service("/slow")


async def test_unadvertised_service_no_longer_answers(bridge, make_client):
    provider = await make_client(bridge.url)
    caller = await make_client(bridge.url)
    await provider.advertise_service("/add", ADD, add_two_ints)
    await wait_for_service(caller, "/add")
    await provider.unadvertise_service("/add")
    async with asyncio.timeout(5):
        while "/add" in (await caller.call_service("/rosapi/services"))["services"]:
            await asyncio.sleep(0.02)
    with pytest.raises(ServiceError):
        await caller.call_service("/add", {"a": 1, "b": 1}, timeout=2.0)


async def test_connection_drop_fails_pending_call_promptly(make_client):
    from bridge.compose import run_bridge
    from bridge.config import BridgeConfig

    async def never(args: dict) -> dict:
        await asyncio.sleep(60)
        return {}

    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as running:
        provider = await make_client(running.url, reconnect=False)
        caller = await make_client(running.url, reconnect=False)
        await provider.advertise_service("/never", ADD, never)
        await wait_for_service(caller, "/never")
        call = asyncio.create_task(caller.call_service("/never", {"a": 1, "b": 1}, timeout=30))
        await asyncio.sleep(0.2)
        started = time.monotonic()
    with pytest.raises(ConnectionClosed):
        await call
    assert time.monotonic() - started < 5.0
    with pytest.raises(ConnectionClosed):
        await caller.call_service("/never", {})
