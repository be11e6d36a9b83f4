"""One Foxglove client as a sans-I/O translator: its frames in, rosbridge ops and frames out.

The client is a core client like any other (a node `/foxglove_client_<n>`); what it asks for
becomes the rosbridge op the core already understands (subscribe with `cbor-raw`, advertise,
publish, call_service, rosapi's set_param), so the graph, the one-delivery rule, the send
queue and the checks are the rosbridge side's. What the core sends back (`Send` effects) is
turned into Foxglove frames by `outgoing`: a topic delivery becomes `MessageData` carrying the
message's shared CDR bytes (`TopicMessage.serialized`, the cbor-raw bytes, no re-encode).

Every client action passes `_refusal` first: the one place a role/permission check applies.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import orjson

from bridge.effects import Send
from bridge.foxglove import wire
from bridge.foxglove.channels import CDR, ChannelTable
from bridge.foxglove.node_parameters import to_ros
from bridge.outgoing import CBOR_RAW, ControlMessage, Delivery, RawFrame, WireFrame
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.message import normalize
from schemas.registry import TypeRegistry
from schemas.safety import echo
from schemas.values import JsonObject, Message

JSON = "json"
PLAYBACK_SERVICE = "/riverbridge/playback/control"
PLAYBACK_TYPE = "riverbridge_msgs/srv/PlaybackControl"
# Ids of the ops this translator sends to the core, by what their answers are for.
SUB, CHANNEL, CALL, PARAM, PLAYBACK = "fg:", "fgc:", "fgs:", "fgp:", "fgpb:"
#: (action, name) -> None to allow, else why not. Actions: subscribe, publish, call,
#: get_param, set_param, fetch_asset, playback, graph.
Permit = Callable[[str, str], str | None]
STATUS_PREFIX = b'{"op":"status"'


def allow_all(action: str, name: str) -> str | None:
    return None


# Not frozen, as its base `Delivery`; no slots of its own: they would hide the compiled base's
# fields (`schemas.runtime.native`).
@dataclass
class FoxgloveDelivery(Delivery):
    """A topic message for one Foxglove subscription: MessageData around the shared CDR."""

    subscription_id: int = 0
    timestamp_ns: int = 0

    def frame(self, link_bytes_per_s: float | None = None) -> WireFrame:
        head = wire.message_data_header(self.subscription_id, self.timestamp_ns)
        return WireFrame(head + self.message.serialized(), text=False)


@dataclass
class Reply:
    """What one client frame asks for: frames to send it, ops to run as it in the core, and
    work for the shell (an asset to read, parameter values to send once `ops` ran)."""

    frames: list[bytes] = field(default_factory=list)
    ops: list[JsonObject] = field(default_factory=list)
    asset: wire.FetchAsset | None = None
    parameters_after: tuple[list[str], str | None] | None = None
    # ROS 2 nodes' parameters to set first (node, parameter, ParameterValue), by the shell.
    node_sets: list[tuple[str, str, Message]] = field(default_factory=list)
    op: str = "?"  # the op or binary opcode of the frame, for log lines
    problems: list[str] = field(default_factory=list)  # what its statuses say


class FoxgloveSession:
    """Per-client protocol state; `receive` a frame, `outgoing` what the core sends it."""

    def __init__(
        self,
        client_id: int,
        table: ChannelTable,
        registry: TypeRegistry,
        permit: Permit = allow_all,
    ) -> None:
        self.client_id = client_id
        self.table = table
        self.registry = registry
        self.permit = permit
        self.subscriptions: dict[int, str] = {}  # subscription id -> topic
        self.by_topic: dict[str, list[int]] = {}
        self.client_channels: dict[int, wire.ClientChannel] = {}
        self.parameter_names: set[str] = set()
        self.graph_subscribed = False
        self.graph_sent = False  # the full graph went out after the client subscribed to it
        # A message's timestamp from when it entered the bridge (the playback clock, if any).
        self.clock: Callable[[int], int] = lambda received_ns: received_ns
        self.calls: dict[str, tuple[int, int, str]] = {}  # op id -> service, call, encoding
        # `/node.param` -> (node, param) when it is a ROS 2 node's parameter, else None
        # (the shell knows the graph: `bridge.foxglove.node_parameters.split_name`).
        self.node_param: Callable[[str], tuple[str, str] | None] = lambda name: None

    # -- inbound ------------------------------------------------------------------------------

    def receive(self, data: bytes | str) -> Reply:
        """Handle one frame; a frame that breaks the protocol is answered with a `status`
        (and listed in `Reply.problems` with the op it concerns, for the log)."""
        reply = Reply()
        try:
            if isinstance(data, str):
                reply.op = "?"
                op = wire.parse_text(data)
                reply.op = op.op
                self._text(op, reply)
            else:
                reply.op = f"binary opcode {data[0]}" if data else "binary"
                self._binary(wire.parse_binary(data), reply)
        except wire.FoxgloveWireError as exc:
            reply.frames.append(wire.status(wire.ERROR, str(exc)))
        reply.problems = [
            orjson.loads(f)["message"] for f in reply.frames if f.startswith(STATUS_PREFIX)
        ]
        return reply

    def _refusal(self, reply: Reply, action: str, name: str) -> bool:
        """The one authorization point: True (and a status) when `action` is not allowed."""
        why = self.permit(action, name)
        if why is not None:
            reply.frames.append(wire.status(wire.ERROR, f"{action} {name}: {why}"))
        return why is not None

    def _text(self, op: wire.ClientOp, reply: Reply) -> None:
        if isinstance(op, wire.Subscribe):
            for request in op.subscriptions:
                self._subscribe(request.id, request.channel_id, reply)
        elif isinstance(op, wire.Unsubscribe):
            for sub_id in op.subscription_ids:
                self._unsubscribe(sub_id, reply)
        elif isinstance(op, wire.Advertise):
            for channel in op.channels:
                self._advertise(channel, reply)
        elif isinstance(op, wire.Unadvertise):
            for channel_id in op.channel_ids:
                self._unadvertise(channel_id, reply)
        elif isinstance(op, wire.GetParameters):
            names = [n for n in op.parameter_names if not self._refusal(reply, "get_param", n)]
            if names or (not op.parameter_names and not self._refusal(reply, "get_param", "")):
                reply.parameters_after = (names, op.id)
        elif isinstance(op, wire.SetParameters):
            self._set_parameters(op, reply)
        elif isinstance(op, wire.SubscribeParameterUpdates):
            names = [n for n in op.parameter_names if not self._refusal(reply, "get_param", n)]
            self.parameter_names.update(names)
        elif isinstance(op, wire.UnsubscribeParameterUpdates):
            self.parameter_names.difference_update(op.parameter_names)
        elif isinstance(op, wire.SubscribeConnectionGraph):
            self.graph_subscribed = not self._refusal(reply, "graph", "")
        elif isinstance(op, wire.UnsubscribeConnectionGraph):
            self.graph_subscribed = self.graph_sent = False
        elif isinstance(op, wire.FetchAsset) and not self._refusal(reply, "fetch_asset", op.uri):
            reply.asset = op

    def _subscribe(self, sub_id: int, channel_id: int, reply: Reply) -> None:
        channel = self.table.by_id.get(channel_id)
        if channel is None:
            reply.frames.append(wire.status(wire.ERROR, f"unknown channel {channel_id}"))
            return
        if sub_id in self.subscriptions:
            reply.frames.append(wire.status(wire.ERROR, f"subscription {sub_id} already exists"))
            return
        if self._refusal(reply, "subscribe", channel.topic):
            return
        self.subscriptions[sub_id] = channel.topic
        self.by_topic.setdefault(channel.topic, []).append(sub_id)
        reply.ops.append(
            {
                "op": "subscribe",
                "id": f"{SUB}{sub_id}",
                "topic": channel.topic,
                "type": channel.type_name,
                "compression": CBOR_RAW,
            }
        )

    def _unsubscribe(self, sub_id: int, reply: Reply) -> None:
        topic = self.subscriptions.pop(sub_id, None)
        if topic is None:
            reply.frames.append(wire.status(wire.WARNING, f"unknown subscription {sub_id}"))
            return
        ids = self.by_topic.get(topic, [])
        ids.remove(sub_id)
        if not ids:
            self.by_topic.pop(topic, None)
        reply.ops.append({"op": "unsubscribe", "id": f"{SUB}{sub_id}", "topic": topic})

    def _advertise(self, channel: wire.ClientChannel, reply: Reply) -> None:
        if channel.encoding not in (CDR, JSON):
            reply.frames.append(
                wire.status(
                    wire.ERROR,
                    f"channel {channel.id} ({echo(channel.topic, 60)}): encoding "
                    f"{echo(channel.encoding, 30)} is not supported (cdr, json)",
                )
            )
            return
        if not self.registry.has_message(channel.schema_name):
            reply.frames.append(
                wire.status(
                    wire.ERROR,
                    f"channel {channel.id}: unknown schema {echo(channel.schema_name, 80)}",
                )
            )
            return
        if self._refusal(reply, "publish", channel.topic):
            return
        self.client_channels[channel.id] = channel
        reply.ops.append(
            {
                "op": "advertise",
                "id": f"{CHANNEL}{channel.id}",
                "topic": channel.topic,
                "type": channel.schema_name,
            }
        )

    def _unadvertise(self, channel_id: int, reply: Reply) -> None:
        channel = self.client_channels.pop(channel_id, None)
        if channel is None:
            reply.frames.append(wire.status(wire.WARNING, f"unknown client channel {channel_id}"))
            return
        reply.ops.append(
            {"op": "unadvertise", "id": f"{CHANNEL}{channel_id}", "topic": channel.topic}
        )

    def _set_parameters(self, op: wire.SetParameters, reply: Reply) -> None:
        names = [parameter.name for parameter in op.parameters]
        for parameter in op.parameters:
            if self._refusal(reply, "set_param", parameter.name):
                continue
            named = self.node_param(parameter.name)
            if named is not None:
                try:
                    reply.node_sets.append((*named, to_ros(parameter)))
                except ValueError as exc:
                    problem = f"setting {echo(parameter.name, 80)} failed: {exc}"
                    reply.frames.append(wire.status(wire.ERROR, problem))
                continue
            reply.ops.append(
                {
                    "op": "call_service",
                    "id": f"{PARAM}{parameter.name}",
                    "service": "/rosapi/set_param",
                    "args": {
                        "name": parameter.name,
                        "value": orjson.dumps(parameter.value).decode(),
                    },
                }
            )
        if op.id is not None:
            reply.parameters_after = (names, op.id)

    def _binary(self, frame: wire.ClientBinary, reply: Reply) -> None:
        if isinstance(frame, wire.ClientMessageData):
            self._publish(frame, reply)
        elif isinstance(frame, wire.ServiceCallRequest):
            self._call(frame, reply)
        elif not self._refusal(reply, "playback", PLAYBACK_SERVICE):
            reply.ops.append(playback_call(frame))

    def _publish(self, frame: wire.ClientMessageData, reply: Reply) -> None:
        channel = self.client_channels.get(frame.channel_id)
        if channel is None:
            reply.frames.append(
                wire.status(wire.ERROR, f"message on unknown client channel {frame.channel_id}")
            )
            return
        try:
            if channel.encoding == CDR:
                msg = from_cdr(self.registry, channel.schema_name, frame.payload)
            else:
                msg = orjson.loads(frame.payload)
        except (SchemaError, orjson.JSONDecodeError, ValueError, KeyError) as exc:
            reply.frames.append(
                wire.status(
                    wire.ERROR,
                    f"channel {frame.channel_id} ({channel.topic}): undecodable "
                    f"{channel.encoding} message: {echo(exc, 120)}",
                )
            )
            return
        reply.ops.append({"op": "publish", "topic": channel.topic, "msg": msg})

    def _call(self, request: wire.ServiceCallRequest, reply: Reply) -> None:
        service = self.table.services_by_id.get(request.service_id)
        problem = None
        if service is None:
            problem = f"unknown service {request.service_id}"
        elif request.encoding not in (CDR, JSON):
            problem = f"encoding {echo(request.encoding, 30)} is not supported (cdr, json)"
        elif self._refusal(reply, "call", service.name):
            return
        args: Any = None
        if service is not None and problem is None:
            try:
                args = (
                    from_cdr(self.registry, service.request_type, request.payload)
                    if request.encoding == CDR
                    else orjson.loads(request.payload)
                )
            except (SchemaError, orjson.JSONDecodeError, ValueError, KeyError) as exc:
                problem = f"undecodable request: {echo(exc, 120)}"
        if problem is not None or service is None:
            reply.frames.append(
                wire.json_frame(
                    "serviceCallFailure",
                    serviceId=request.service_id,
                    callId=request.call_id,
                    message=problem,
                )
            )
            return
        op_id = f"{CALL}{request.service_id}:{request.call_id}"
        self.calls[op_id] = (request.service_id, request.call_id, request.encoding)
        reply.ops.append(
            {
                "op": "call_service",
                "id": op_id,
                "service": service.name,
                "type": service.type_name,
                "args": args,
            }
        )

    # -- outbound -----------------------------------------------------------------------------

    def outgoing(self, send: Send) -> list[Send]:
        """What the core sends this client, as Foxglove frames (nothing for what has none)."""
        item = send.item
        if isinstance(item, Delivery):
            stamp_ns = self.clock(item.message.stamp_ns)
            return [
                Send(
                    self.client_id,
                    FoxgloveDelivery(
                        item.message,
                        item.topic,
                        CBOR_RAW,
                        subscription_id=sub_id,
                        timestamp_ns=stamp_ns,
                    ),
                    send.drop_key,
                )
                for sub_id in self.by_topic.get(item.message.topic, ())
            ]
        if isinstance(item, ControlMessage):
            frame = self._answer(item.payload)
            return [] if frame is None else [self.frame(frame, text=frame[:1] == b"{")]
        return [send]

    def frame(self, data: bytes, *, text: bool, drop_key: str | None = None) -> Send:
        return Send(self.client_id, RawFrame(WireFrame(data, text)), drop_key)

    def _answer(self, payload: Mapping[str, Any]) -> bytes | None:
        op, op_id = payload.get("op"), payload.get("id")
        if op == "status":
            return wire.status(wire.ERROR, str(payload.get("msg", "")))
        if op != "service_response" or not isinstance(op_id, str):
            return None
        ok, values = payload.get("result") is True, payload.get("values")
        if op_id.startswith(CALL):
            return self._call_answer(op_id, ok, values)
        if op_id.startswith(PARAM) and not ok:
            return wire.status(wire.ERROR, f"setting {op_id[len(PARAM) :]} failed: {values}")
        if op_id.startswith(PLAYBACK):
            return playback_answer(op_id[len(PLAYBACK) :], ok, values)
        return None

    def _call_answer(self, op_id: str, ok: bool, values: Any) -> bytes | None:
        call = self.calls.pop(op_id, None)
        if call is None:
            return None
        service_id, call_id, encoding = call
        service = self.table.services_by_id.get(service_id)
        if ok and service is not None and isinstance(values, dict):
            try:
                payload = (
                    to_cdr(
                        self.registry,
                        service.response_type,
                        normalize(self.registry.message(service.response_type), values, now_ns=0),
                    )
                    if encoding == CDR
                    else orjson.dumps(values)
                )
            except (SchemaError, ValueError, KeyError, TypeError) as exc:
                values, ok = f"response does not encode: {echo(exc, 120)}", False
            else:
                return wire.service_call_response(service_id, call_id, encoding, payload)
        return wire.json_frame(
            "serviceCallFailure", serviceId=service_id, callId=call_id, message=str(values)
        )

    def parameter_values(
        self,
        names: list[str],
        params: Mapping[str, str],
        request_id: str | None,
        nodes: list[dict[str, Any]] | None = None,
    ) -> bytes:
        """`parameterValues` for `names` (every parameter when empty); unknown ones left out.
        `nodes`: ROS 2 nodes' parameters already in Foxglove's shape, sent after the own."""
        chosen = names or sorted(params)
        values = [
            {"name": name, "value": orjson.loads(params[name])} for name in chosen if name in params
        ] + (nodes or [])
        fields: dict[str, Any] = {"parameters": values}
        if request_id is not None:
            fields["id"] = request_id
        return wire.json_frame("parameterValues", **fields)


def playback_call(request: wire.PlaybackControlRequest) -> JsonObject:
    """The player's control service call for a `PlaybackControlRequest`."""
    seek_sec, seek_nanosec = divmod(request.seek_ns or 0, 1_000_000_000)
    return {
        "op": "call_service",
        "id": f"{PLAYBACK}{request.request_id}",
        "service": PLAYBACK_SERVICE,
        "type": PLAYBACK_TYPE,
        "args": {
            "play": request.play,
            "speed": request.speed,
            "seek": request.seek_ns is not None,
            "seek_time": {"sec": seek_sec, "nanosec": seek_nanosec},
        },
    }


def playback_answer(request_id: str, ok: bool, values: Any) -> bytes:
    """The player's answer as `PlaybackState`, or a status when it has none."""
    if not ok or not isinstance(values, dict):
        return wire.status(wire.ERROR, f"playback control failed: {values}")
    return wire.playback_state(
        int(values.get("status", wire.PAUSED)),
        stamp_ns(values.get("current_time")),
        float(values.get("speed", 1.0)),
        bool(values.get("did_seek", False)),
        request_id,
    )


def stamp_ns(stamp: Any) -> int:
    """A `builtin_interfaces/Time` dict in ns (0 when absent)."""
    if not isinstance(stamp, dict):
        return 0
    return int(stamp.get("sec", 0)) * 1_000_000_000 + int(stamp.get("nanosec", 0))
