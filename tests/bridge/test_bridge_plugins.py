"""A plug-in of our own through the `PluginHost` (bridge.host), seen by a real websocket client:
what a graph transport may do (list remote nodes and endpoints, publish into the graph, take
what clients publish, answer calls, provide a service through an in-process client) and that
stopping it takes all of it away again."""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
import websockets

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from bridge.context import Context
from bridge.effects import Send
from bridge.host import PluginHost
from bridge.outgoing import ControlMessage, TopicMessage

pytestmark = pytest.mark.timeout(60)

SOURCE = "shore"
NODE = "/shore_station"


class ShoreGraph:
    """A toy graph transport: one remote node with a topic, a service and a status call."""

    def __init__(self, host: PluginHost) -> None:
        self.host = host
        self.heard: list[tuple[str, dict[str, Any], str]] = []
        self.server_id: int | None = None

    async def start(self) -> None:
        host = self.host
        host.add_sink(self)
        host.set_external_nodes(SOURCE, {NODE})
        host.add_remote_publisher("/shore/depth", "std_msgs/msg/Float32", NODE, SOURCE)
        host.add_remote_subscriber("/chatter", "std_msgs/msg/String", NODE)
        host.answer_service("/shore/ping", "std_srvs/srv/Trigger", self.ping)
        self.server_id = host.connect_internal(NODE, self.server_receives, peer=SOURCE)
        host.send_op(
            self.server_id,
            {"op": "advertise_service", "service": "/shore/gate", "type": "std_srvs/srv/SetBool"},
        )

    async def stop(self) -> None:
        host = self.host
        host.remove_sink(self)
        host.stop_answering("/shore/ping")
        host.remove_remote_publisher("/shore/depth", NODE)
        host.remove_remote_subscriber("/chatter", NODE)
        host.set_external_nodes(SOURCE, ())
        if self.server_id is not None:
            host.disconnect_internal(self.server_id)

    def accept(self, ctx: Context, message: TopicMessage, origin_node: str) -> None:
        self.heard.append((message.topic, message.msg, origin_node))

    def ping(self, ctx: Context, request: dict[str, Any]) -> dict[str, Any]:
        return {"success": True, "message": "shore here"}

    def server_receives(self, send: Send) -> None:
        """The core forwards a call to our in-process provider: answer it on the next turn."""
        assert isinstance(send.item, ControlMessage)
        call = send.item.payload
        if call.get("op") != "call_service" or self.server_id is None:
            return
        args = call.get("args")
        opened = bool(args.get("data")) if isinstance(args, dict) else False
        answer = {
            "op": "service_response",
            "service": call["service"],
            "id": call["id"],
            "values": {"success": opened, "message": "gate open" if opened else "gate shut"},
            "result": True,
        }
        asyncio.get_running_loop().call_soon(self.host.send_op, self.server_id, answer)


async def next_op(ws, op: str, op_id: str | None = None) -> dict[str, Any]:
    async with asyncio.timeout(10):
        while True:
            reply: dict[str, Any] = json.loads(await ws.recv())
            if reply.get("op") == op and reply.get("id") == op_id:
                return reply


async def call(ws, service: str, args: dict[str, Any] | None = None) -> dict[str, Any]:
    ask = {"op": "call_service", "service": service, "args": args or {}, "id": service}
    await ws.send(json.dumps(ask))
    reply = await next_op(ws, "service_response", service)
    assert reply["result"] is True, reply
    values: dict[str, Any] = reply["values"]
    return values


async def test_a_plugin_changes_the_graph_only_through_its_host(registry):
    async with run_bridge(BridgeConfig(port=0), registry, more=[(SOURCE, ShoreGraph)]) as bridge:
        plugin = bridge.plugins[SOURCE]
        assert isinstance(plugin, ShoreGraph)
        async with websockets.connect(bridge.url) as ws:
            assert NODE in (await call(ws, "/rosapi/nodes"))["nodes"]
            topics = await call(ws, "/rosapi/topics")
            assert dict(zip(topics["topics"], topics["types"], strict=True))["/shore/depth"] == (
                "std_msgs/msg/Float32"
            )
            assert (await call(ws, "/rosapi/publishers", {"topic": "/shore/depth"}))[
                "publishers"
            ] == [NODE]
            assert (await call(ws, "/shore/ping"))["success"] is True
            assert await call(ws, "/shore/gate", {"data": True}) == {
                "success": True,
                "message": "gate open",
            }
            await ws.send(json.dumps({"op": "subscribe", "topic": "/shore/depth", "id": "s"}))
            await call(ws, "/rosapi/get_time")  # the subscription is in place once this returns
            plugin.host.publish_external(
                NODE, "/shore/depth", "std_msgs/msg/Float32", {"data": 4.5}
            )
            published = await next_op(ws, "publish")
            assert published["topic"] == "/shore/depth" and published["msg"] == {"data": 4.5}
            await ws.send(
                json.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": "ahoy"}})
            )
            await call(ws, "/rosapi/get_time")
            websocket_client = f"/rosbridge_client_{plugin.server_id + 1}"  # after ours
            assert ("/chatter", {"data": "ahoy"}, websocket_client) in plugin.heard
    state = bridge.core.state
    assert NODE not in state.external_nodes and "/shore/ping" not in state.rosapi
    assert "/shore/depth" not in state.graph.topics and "/shore/gate" not in state.graph.services
    assert plugin not in state.sinks
