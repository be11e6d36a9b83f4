"""Updates of ROS 2 nodes' parameters for Foxglove subscribers, from `/parameter_events`.

rcl nodes publish every change of their parameters on `/parameter_events`
(`rcl_interfaces/msg/ParameterEvent`: the node, its new, changed and deleted parameters),
which is how foxglove_bridge follows them. While a Foxglove client subscribes to some node's
parameter, the plug-in subscribes to that topic as an in-process client of the core (through
the DDS mirror like any subscriber); each event's new and changed parameters become
`/node.param` values for the clients subscribed to them (`FoxglovePlugin.tell_node_parameters`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from bridge.effects import Send
from bridge.foxglove.node_parameters import to_foxglove
from bridge.host import PluginHost
from bridge.outgoing import Delivery

EVENTS_TOPIC = "/parameter_events"
EVENTS_TYPE = "rcl_interfaces/msg/ParameterEvent"
NODE = "foxglove_parameter_events"


class ParameterEvents:
    """The plug-in's subscription to `/parameter_events`, held while someone wants it."""

    def __init__(self, host: PluginHost, tell: Callable[[list[dict[str, Any]]], None]) -> None:
        self._host = host
        self._tell = tell
        self._client: int | None = None

    def follow(self, wanted: bool) -> None:
        """Subscribe while `wanted`, leave when not (a no-op when already so)."""
        if wanted and self._client is None:
            self._client = self._host.connect_internal(NODE, self._receive)
            subscribe = {"op": "subscribe", "id": NODE, "topic": EVENTS_TOPIC}
            self._host.send_op(self._client, {**subscribe, "type": EVENTS_TYPE})
        elif not wanted and self._client is not None:
            self._host.disconnect_internal(self._client)
            self._client = None

    def _receive(self, send: Send) -> None:
        if isinstance(send.item, Delivery):
            changed = event_parameters(send.item.message.msg)
            if changed:
                self._tell(changed)


def event_parameters(event: dict[str, Any]) -> list[dict[str, Any]]:
    """A ParameterEvent's new and changed parameters as Foxglove parameters of its node."""
    node = "/" + str(event.get("node", "")).strip("/")
    listed = [*(event.get("new_parameters") or []), *(event.get("changed_parameters") or [])]
    shown = (to_foxglove(node, str(p.get("name", "")), p.get("value") or {}) for p in listed)
    return [parameter for parameter in shown if parameter is not None]
