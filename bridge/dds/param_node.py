"""The bridge's own parameters served as a ROS 2 node serves its own, on DDS.

The bridge keeps parameters for rosapi (`/rosapi/get_param`, `set_param`,
`get_param_names`). Its DDS node (`/riverbridge_<id>` or `--dds-node`) offers them through
rcl_interfaces' services, `<node>/list_parameters`, `get_parameters`, `set_parameters`,
`describe_parameters` and `get_parameter_types`, so ROS 2 tools (`ros2 param
list/get/set/describe`) reach them. Gets and sets become rosapi calls of an in-process
client, and their answers make the reply; lists, descriptions and types are read from the
bridge's parameters directly. Values cross as rosapi's JSON text
(`bridge.rosapi.node_params`). A name the bridge does not keep is NOT_SET, as in ROS 2.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from bridge.dds.participant import DdsPlumbing
from bridge.dds.request_header import RequestId
from bridge.dds.service_endpoints import ServiceServer
from bridge.effects import Send
from bridge.errors import RosapiError
from bridge.host import PluginHost
from bridge.outgoing import ControlMessage
from bridge.rosapi.node_params import NOT_SET, parameter_value, value_json
from schemas.errors import DecodeError
from schemas.message import normalize
from schemas.values import JsonObject, Message

logger = logging.getLogger("bridge.dds")

VALUE_TYPE = "rcl_interfaces/msg/ParameterValue"
SERVICES = {
    "list_parameters": "rcl_interfaces/srv/ListParameters",
    "get_parameters": "rcl_interfaces/srv/GetParameters",
    "set_parameters": "rcl_interfaces/srv/SetParameters",
    "describe_parameters": "rcl_interfaces/srv/DescribeParameters",
    "get_parameter_types": "rcl_interfaces/srv/GetParameterTypes",
}


@dataclass
class _Request:
    """One DDS request waiting for the rosapi answers it asked for (in order)."""

    server: ServiceServer
    request: RequestId
    compose: Callable[[list[Message]], Message]
    answers: dict[str, Message] = field(default_factory=dict)
    call_ids: list[str] = field(default_factory=list)


class ParamNode:
    """`<node>/{list,get,set}_parameters` on DDS, answered from the bridge's parameters."""

    def __init__(
        self,
        host: PluginHost,
        dds: DdsPlumbing,
        node: str,
        own_clients: set[int],
        to_loop: Callable[..., object],
    ) -> None:
        self._host = host
        self.client = host.connect_internal(f"{node}_parameters", self._receives, peer="dds")
        own_clients.add(self.client)  # the mirror's own: never a websocket client's node
        self._waiting: dict[str, _Request] = {}  # rosapi call id -> its DDS request
        self._value_spec = dds.registry.message(VALUE_TYPE)  # fills the unused fields
        self._registry = dds.registry
        self._calls = 0
        handlers = {
            "list_parameters": self._list,
            "get_parameters": self._get,
            "set_parameters": self._set,
            "describe_parameters": self._describe,
            "get_parameter_types": self._types,
        }
        self.servers = [
            ServiceServer(
                dds,
                f"{node}/{name}",
                type_name,
                lambda *args, handler=handlers[name]: to_loop(handler, *args),
            )
            for name, type_name in SERVICES.items()
        ]

    def _ask(self, pending: _Request, calls: list[tuple[str, JsonObject]]) -> None:
        """Send the rosapi calls of one DDS request; reply once all are answered."""
        for _call in calls:
            self._calls += 1
            call_id = f"dds_param:{self._calls}"
            pending.call_ids.append(call_id)
            self._waiting[call_id] = pending
        for call_id, (service, args) in zip(pending.call_ids, calls, strict=True):
            op: JsonObject = {"op": "call_service", "service": service, "args": args}
            self._host.send_op(self.client, {**op, "id": call_id})
        if not calls:
            pending.server.send(pending.request, pending.compose([]))

    def _list(self, _service: str, request: RequestId, msg: Message) -> None:
        # Its own names only, read directly: rosapi's get_param_names also asks other nodes
        # (another bridge's node asking this one's would go round in a circle).
        names = sorted(self._host.parameters())
        self.servers[0].send(request, {"result": {"names": names, "prefixes": []}})

    def _describe(self, _service: str, request: RequestId, msg: Message) -> None:
        names = [str(name) for name in msg.get("names", [])]
        descriptors = [{"name": name, "type": self._type_of(name)} for name in names]
        self._answer_now(3, {"descriptors": descriptors}, request)

    def _types(self, _service: str, request: RequestId, msg: Message) -> None:
        types = [self._type_of(str(name)) for name in msg.get("names", [])]
        self._answer_now(4, {"types": types}, request)

    def _type_of(self, name: str) -> int:
        """The ParameterType of one of the bridge's parameters (NOT_SET if it has none)."""
        text = self._host.parameters().get(name)
        return int(_as_parameter_value({"successful": text is not None, "value": text})["type"])

    def _answer_now(self, index: int, values: Message, request: RequestId) -> None:
        server = self.servers[index]
        spec = self._registry.service(list(SERVICES.values())[index]).response
        server.send(request, normalize(spec, values, now_ns=0))

    def _get(self, _service: str, request: RequestId, msg: Message) -> None:
        names = [str(name) for name in msg.get("names", [])]

        def compose(answers: list[Message]) -> Message:
            values = [_as_parameter_value(answer) for answer in answers]
            return {"values": [normalize(self._value_spec, v, now_ns=0) for v in values]}

        calls = [("/rosapi/get_param", {"name": name}) for name in names]
        self._ask(_Request(self.servers[1], request, compose), calls)

    def _set(self, _service: str, request: RequestId, msg: Message) -> None:
        parameters = list(msg.get("parameters", []))

        def compose(answers: list[Message]) -> Message:
            return {
                "results": [
                    {
                        "successful": bool(answer.get("successful")),
                        "reason": str(answer.get("reason", "")),
                    }
                    for answer in answers
                ]
            }

        calls = [
            ("/rosapi/set_param", {"name": str(p.get("name")), "value": value_json(p["value"])})
            for p in parameters
        ]
        self._ask(_Request(self.servers[2], request, compose), calls)

    def _receives(self, send: Send) -> None:
        payload = send.item.payload if isinstance(send.item, ControlMessage) else {}
        call_id = str(payload.get("id"))
        pending = self._waiting.pop(call_id, None)
        if pending is None or payload.get("op") != "service_response":
            return
        values = payload.get("values")
        pending.answers[call_id] = (
            values
            if payload.get("result") is True and isinstance(values, dict)
            else {"successful": False, "reason": str(values)}
        )
        if len(pending.answers) == len(pending.call_ids):
            answers = [pending.answers[c] for c in pending.call_ids]
            pending.server.send(pending.request, pending.compose(answers))

    def guids(self) -> tuple[list[bytes], list[bytes]]:
        pairs = [server.guids() for server in self.servers]
        return [r for r, _ in pairs], [w for _, w in pairs]

    def close(self) -> None:
        for server in self.servers:
            server.close()
        self._host.disconnect_internal(self.client)


def _as_parameter_value(answer: Message) -> Any:
    """A rosapi get_param answer as a ParameterValue (NOT_SET if unset or not one)."""
    if not answer.get("successful"):
        return {"type": NOT_SET}
    try:
        return parameter_value(str(answer.get("value", "null")))
    except (RosapiError, DecodeError):
        logger.debug("DDS: parameter value %r has no ROS 2 type", answer.get("value"))
        return {"type": NOT_SET}
