"""Roles for Foxglove clients: a bridge token at the handshake (`?token=`) lets a Foxglove
client in, and its role decides what it may do, as for a rosbridge client (host.authorize)."""

from __future__ import annotations

import asyncio
import json
import time
from typing import Any

import orjson
import pytest
import websockets
from pydantic import SecretStr

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from schemas import tokens
from schemas.roles_config import RolesConfig

pytestmark = pytest.mark.timeout(60)

FOXGLOVE = "foxglove.websocket.v1"
SECRET = "foxglove-roles-secret-0123456789abcdef"
ROLES = RolesConfig.model_validate(
    {"roles": {"observer": {"subscribe": ["*"], "get_param": ["*"]}}}
)


async def next_json(ws: Any, op: str) -> dict[str, Any]:
    while True:
        data = await asyncio.wait_for(ws.recv(), 10)
        if isinstance(data, str) and (message := json.loads(data))["op"] == op:
            return message


async def test_a_foxglove_observer_with_a_token_looks_but_cannot_set() -> None:
    config = BridgeConfig(port=0, auth_secret=SecretStr(SECRET), roles=ROLES)
    token = tokens.issue(SECRET, "observer", "lichtblick", time.time(), 60)
    async with run_bridge(config) as bridge:
        async with websockets.connect(
            f"{bridge.url}/?token={token}", subprotocols=[FOXGLOVE]
        ) as ws:
            channels = (await next_json(ws, "advertise"))["channels"]
            rosout = next(c for c in channels if c["topic"] == "/rosout")
            subscribe = {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": rosout["id"]}]}
            await ws.send(orjson.dumps(subscribe).decode())
            setting = {"op": "setParameters", "parameters": [{"name": "gain", "value": 2}]}
            await ws.send(orjson.dumps(setting).decode())
            status = await next_json(ws, "status")
            assert status["level"] == 2
            assert "role observer may not set param gain" in status["message"]
            # the set was refused after the subscribe was handled: it is in place
            assert "/rosout" in bridge.core.state.topic_subscriptions
            assert [s.role for s in bridge.core.state.sessions.values()] == ["observer"]
        assert "gain" not in bridge.core.state.params
        async with websockets.connect(bridge.url, subprotocols=[FOXGLOVE]) as anonymous:
            await next_json(anonymous, "advertise")
            await anonymous.send(orjson.dumps(subscribe).decode())
            refused = await next_json(anonymous, "status")
            assert "not authenticated: connect with ?token=" in refused["message"]
