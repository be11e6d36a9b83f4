"""Fixtures for the client tests: a real bridge on 127.0.0.1 port 0, and connected clients."""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from schemas.registry import TypeRegistry


@pytest.fixture
async def bridge() -> AsyncIterator[Any]:
    """A running bridge; ``.url`` is its ws:// address."""
    async with run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as running:
        yield running


@pytest.fixture
async def make_client(
    registry: TypeRegistry,
) -> AsyncIterator[Callable[..., Awaitable[RosbridgeClient]]]:
    """Connects clients (shared type registry) and closes them all at teardown."""
    made: list[RosbridgeClient] = []

    async def make(url: str, **kwargs: Any) -> RosbridgeClient:
        kwargs.setdefault("registry", registry)
        kwargs.setdefault("connect_timeout", 5.0)
        client = RosbridgeClient(url, **kwargs)
        made.append(client)
        await client.connect()
        return client

    yield make
    for client in made:
        await client.close()
