"""Sans-I/O rosbridge v2 client protocol: op frames out, routed events in.

:class:`ClientProtocol` holds everything a connection must remember (subscriptions,
advertisements, advertised services, pending calls and goals, partial fragments) and never
touches a socket, a clock or the event loop: time (``recv_ns``, used for ``"now"`` stamps) is
passed in, frames are returned to the caller to send. That makes every rule of the protocol
testable without a network and lets :mod:`clients.client` stay a thin pump.

ids follow roslibpy (reference/rosbridge-clients.md §2): ``"<op>:<name>:<n>"`` with one counter
per protocol instance, e.g. ``subscribe:/imu:3``. They survive a reconnect: the same ids are
re-sent by :meth:`ClientProtocol.resume_frames`.

Thread safety: only :meth:`decode` may run on another thread (it reads an immutable snapshot
of the topic-to-type table, replaced as a whole on every change); every other method belongs
to the thread that owns the protocol.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Literal, TypedDict

from clients.errors import ProtocolError
from clients.events import (
    ActionFeedback,
    ActionOutcome,
    Event,
    GoalCancel,
    GoalRequest,
    Ignored,
    Received,
    ServiceReply,
    ServiceRequest,
    TopicMessage,
)
from clients.fragments import FragmentAssembler
from clients.inbound import OpRoute, Route, route
from clients.wire import Frame, decode_frame, op_frame
from schemas import ops
from schemas.errors import SchemaError
from schemas.frames import publish_cbor, publish_json
from schemas.message import normalize
from schemas.ops import OpError

logger = logging.getLogger(__name__)

Encoding = Literal["json", "cbor"]
Compression = Literal["none", "png", "cbor", "cbor-raw"]

DEFAULT_QUEUE_SIZE = 100
"""Publisher queue depth sent with ``advertise``: rosbridge's default (protocol §2.1)."""


@dataclass(frozen=True, slots=True)
class SubscriptionRecord:
    """A subscription as sent to the bridge; kept to re-subscribe after a reconnect."""

    sub_id: str
    topic: str
    type: str | None
    throttle_rate_ms: int
    queue_length: int
    compression: Compression
    fragment_size: int | None = None
    reduce: Mapping[str, Any] | None = None


@dataclass(frozen=True, slots=True)
class AdvertiseRecord:
    """An advertised topic, kept to re-advertise after a reconnect."""

    advert_id: str
    topic: str
    type: str
    latch: bool
    queue_size: int


class ClientProtocol:
    """State machine of one rosbridge client connection (survives reconnects).

    encoding : "json" sends publishes as JSON text, "cbor" as CBOR binary; control ops are
        always JSON text, which every rosbridge server reads.
    spec_lookup : message type name -> spec for :func:`schemas.message.normalize`, usually
        ``TypeRegistry.message``; raises :class:`schemas.errors.SchemaError` for unknown types.
    """

    def __init__(self, *, encoding: Encoding, spec_lookup: Callable[[str], Any]) -> None:
        if encoding not in ("json", "cbor"):
            raise ValueError(f"encoding must be 'json' or 'cbor', not {encoding!r}")
        self.encoding: Encoding = encoding
        self._spec_lookup = spec_lookup
        self._counter = itertools.count(1)
        self._subs: dict[str, SubscriptionRecord] = {}
        self._adverts: dict[str, AdvertiseRecord] = {}
        self._services: dict[str, str] = {}
        self._actions: dict[str, str] = {}
        self._calls: dict[str, str] = {}
        self._goals: dict[str, str] = {}
        self._topic_specs: Mapping[str, Any] = MappingProxyType({})
        self._topic_index: Mapping[str, tuple[str, ...]] = MappingProxyType({})
        self._fragments = FragmentAssembler()

    # ----------------------------------------------------------------- ids and state views
    def next_id(self, op: str, name: str) -> str:
        """A fresh roslibpy-style id ``"<op>:<name>:<n>"``."""
        return f"{op}:{name}:{next(self._counter)}"

    @property
    def subscriptions(self) -> Mapping[str, SubscriptionRecord]:
        """Active subscriptions by id (read-only view)."""
        return MappingProxyType(self._subs)

    @property
    def advertisements(self) -> Mapping[str, AdvertiseRecord]:
        """Advertised topics by topic name (read-only view)."""
        return MappingProxyType(self._adverts)

    @property
    def services(self) -> Mapping[str, str]:
        """Services this client provides: name -> type (read-only view)."""
        return MappingProxyType(self._services)

    def default_compression(self) -> Compression:
        """``cbor`` on a CBOR connection, ``none`` (JSON) on a JSON one."""
        return "cbor" if self.encoding == "cbor" else "none"

    # ------------------------------------------------------------------------ topics out
    def advertise(
        self, topic: str, type: str, *, latch: bool = False, queue_size: int = DEFAULT_QUEUE_SIZE
    ) -> Frame:
        """Register ``topic`` as published by us and return the ``advertise`` frame."""
        previous = self._adverts.get(topic)
        advert_id = previous.advert_id if previous else self.next_id("advertise", topic)
        record = AdvertiseRecord(advert_id, topic, type, latch, queue_size)
        frame = _advertise_frame(record)
        self._adverts[topic] = record
        return frame

    def unadvertise(self, topic: str) -> Frame | None:
        """Forget an advertisement; ``None`` when the topic was not advertised."""
        record = self._adverts.pop(topic, None)
        if record is None:
            return None
        return op_frame(ops.Unadvertise, id=record.advert_id, topic=topic)

    def encode_publish(self, topic: str, msg: dict[str, Any]) -> Frame:
        """Encode one ``publish`` in the connection encoding (pure, safe on any thread).

        ``msg`` in canonical form (bytes, ndarrays) or plain JSON-able values. Cost grows with
        the payload (~1 ms CBOR / ~30 ms JSON for a 4 MB scan), so callers move big ones off
        the event loop.

        The one op not built through its :class:`schemas.ops.Publish` model: validating it
        costs ~2 µs (``model_construct`` ~9 µs), a third of encoding a whole Imu frame (~6 µs),
        and would check nothing a typed call does not (``topic: str``, ``msg: Message``; the
        payload is never walked by the model anyway). It uses the bridge's own typed
        ``schemas.frames.publish_*`` instead, so both sides write publish frames one way
        (benchmarks/client_ops.py measures it).
        """
        if self.encoding == "cbor":
            return Frame(publish_cbor(topic, msg), text=False)
        return Frame(publish_json(topic, msg), text=True)

    # ------------------------------------------------------------------- subscriptions
    def subscribe(
        self,
        topic: str,
        type: str | None = None,
        *,
        throttle_rate_ms: int = 0,
        queue_length: int = 0,
        compression: Compression | None = None,
        fragment_size: int | None = None,
        reduce: Mapping[str, Any] | None = None,
    ) -> tuple[str, Frame]:
        """Register a subscription; return its id and the ``subscribe`` frame.

        With ``type`` given, incoming messages are normalized to canonical form; an unknown
        type raises :class:`schemas.errors.SchemaError` here, before anything is sent.
        """
        if type is not None:
            self._spec_lookup(type)
        sub_id = self.next_id("subscribe", topic)
        record = SubscriptionRecord(
            sub_id,
            topic,
            type,
            int(throttle_rate_ms),
            int(queue_length),
            compression or self.default_compression(),
            fragment_size,
            reduce,
        )
        frame = _subscribe_frame(record)
        self._subs[sub_id] = record
        self._reindex()
        return sub_id, frame

    def unsubscribe(self, sub_id: str) -> Frame | None:
        """Drop one subscription id; ``None`` when it was not active."""
        record = self._subs.pop(sub_id, None)
        if record is None:
            return None
        self._reindex()
        return op_frame(ops.Unsubscribe, id=sub_id, topic=record.topic)

    def _reindex(self) -> None:
        """Rebuild topic -> ids and the topic -> spec snapshot read by :meth:`decode`.

        Both are replaced whole (copy-on-write), never mutated, so a worker thread in
        :meth:`decode` always sees a consistent table.
        """
        specs: dict[str, Any] = {}
        index: dict[str, tuple[str, ...]] = {}
        raw_topics = set()
        for record in self._subs.values():
            index[record.topic] = (*index.get(record.topic, ()), record.sub_id)
            if record.compression == "cbor-raw":
                raw_topics.add(record.topic)
            elif record.type is not None:
                specs.setdefault(record.topic, self._spec_lookup(record.type))
        for topic in raw_topics:
            specs.pop(topic, None)
        self._topic_specs = MappingProxyType(specs)
        self._topic_index = MappingProxyType(index)

    # ------------------------------------------------------------------------ services
    def call_service(
        self,
        service: str,
        args: Any = None,
        *,
        type: str | None = None,
        timeout_s: float | None = None,
    ) -> tuple[str, Frame]:
        """Start a call; return its id and the ``call_service`` frame."""
        call_id = self.next_id("call_service", service)
        optional: _CallOptions = {}
        if type is not None:
            optional["type"] = type
        if timeout_s is not None:
            optional["timeout"] = float(timeout_s)
        frame = op_frame(
            ops.CallService,
            id=call_id,
            service=service,
            args={} if args is None else args,
            **optional,
        )
        self._calls[call_id] = service
        return call_id, frame

    def forget_call(self, call_id: str) -> None:
        """Stop waiting for a call (timed out or cancelled); a late reply is then ignored."""
        self._calls.pop(call_id, None)

    def advertise_service(self, service: str, type: str) -> Frame:
        """Provide ``service``; calls arrive as :class:`ServiceRequest` events."""
        frame = op_frame(ops.AdvertiseService, type=type, service=service)
        self._services[service] = type
        return frame

    def unadvertise_service(self, service: str) -> Frame | None:
        """Stop providing ``service``; ``None`` when it was not advertised."""
        if self._services.pop(service, None) is None:
            return None
        return op_frame(ops.UnadvertiseService, service=service)

    @staticmethod
    def service_response(request: ServiceRequest, values: Any, *, result: bool) -> Frame:
        """Answer a :class:`ServiceRequest` (``values``: a dict, or the error text on failure)."""
        return op_frame(
            ops.ServiceResponse,
            service=request.service,
            values=values,
            result=result,
            id=request.request_id,
        )

    # ------------------------------------------------------------------------- actions
    def send_action_goal(
        self, action: str, action_type: str, args: Any = None, *, feedback: bool = True
    ) -> tuple[str, Frame]:
        """Send a goal; feedback and the result arrive as events keyed by the returned id."""
        goal_id = self.next_id("send_action_goal", action)
        frame = op_frame(
            ops.SendActionGoal,
            id=goal_id,
            action=action,
            action_type=action_type,
            args={} if args is None else args,
            feedback=feedback,
        )
        self._goals[goal_id] = action
        return goal_id, frame

    def cancel_action_goal(self, goal_id: str) -> Frame | None:
        """Ask the server to cancel a goal; the final :class:`ActionOutcome` still follows."""
        action = self._goals.get(goal_id)
        if action is None:
            return None
        return op_frame(ops.CancelActionGoal, id=goal_id, action=action)

    def forget_goal(self, goal_id: str) -> None:
        """Stop tracking a goal (finished, or its caller gave up)."""
        self._goals.pop(goal_id, None)

    def advertise_action(self, action: str, type: str) -> Frame:
        """Serve ``action``; goals arrive as :class:`GoalRequest`, cancels as GoalCancel."""
        frame = op_frame(ops.AdvertiseAction, type=type, action=action)
        self._actions[action] = type
        return frame

    def unadvertise_action(self, action: str) -> Frame | None:
        """Stop serving ``action``; ``None`` when it was not advertised."""
        if self._actions.pop(action, None) is None:
            return None
        return op_frame(ops.UnadvertiseAction, action=action)

    @staticmethod
    def action_feedback(goal: GoalRequest, values: Any) -> Frame:
        """Progress of a goal we serve."""
        return op_frame(ops.ActionFeedback, id=goal.goal_id, action=goal.action, values=values)

    @staticmethod
    def action_result(goal: GoalRequest, values: Any, *, status: int, result: bool) -> Frame:
        """Final answer for a goal we serve (status: action_msgs/GoalStatus)."""
        return op_frame(
            ops.ActionResult,
            id=goal.goal_id,
            action=goal.action,
            values=values,
            status=status,
            result=result,
        )

    # ---------------------------------------------------------------------- connection
    def resume_frames(self) -> list[Frame]:
        """Frames that restore our registrations on a fresh connection, in a safe order.

        Advertisements first (so a latched publisher exists before anyone subscribes), then
        services and actions, then subscriptions; all with their original ids.
        """
        frames = [_advertise_frame(r) for r in self._adverts.values()]
        frames += [
            op_frame(ops.AdvertiseService, type=t, service=s) for s, t in self._services.items()
        ]
        frames += [
            op_frame(ops.AdvertiseAction, type=t, action=a) for a, t in self._actions.items()
        ]
        frames += [_subscribe_frame(r) for r in self._subs.values()]
        return frames

    def connection_lost(self) -> tuple[list[str], list[str]]:
        """Forget in-flight calls and goals (their answers cannot come) and partial fragments.

        Returns (call ids, goal ids) that the caller must fail.
        """
        calls, goals = list(self._calls), list(self._goals)
        self._calls.clear()
        self._goals.clear()
        self._fragments = FragmentAssembler()
        return calls, goals

    # ------------------------------------------------------------------------ incoming
    def decode(self, data: bytes | str, *, recv_ns: int) -> dict[str, Any]:
        """Decode a payload into an op; ``publish`` messages of typed topics come normalized.

        Safe to call from a worker thread. Raises :class:`ProtocolError`.
        """
        op = decode_frame(data)
        if op["op"] == "publish":
            topic = op.get("topic")
            spec = self._topic_specs.get(topic) if isinstance(topic, str) else None
            if spec is not None:
                try:
                    op["msg"] = normalize(spec, op.get("msg") or {}, now_ns=recv_ns)
                except SchemaError as exc:
                    raise ProtocolError(f"publish on {op.get('topic')}: {exc}") from exc
        return op

    def receive(self, data: bytes | str, *, recv_ns: int) -> list[Event]:
        """Decode and route one payload (convenience for small frames and tests).

        ``wire_bytes`` is ``len(data)``: for text frames that counts characters, equal to bytes
        for the ASCII-only JSON that rosbridge servers send.
        """
        return self.handle(
            self.decode(data, recv_ns=recv_ns), recv_ns=recv_ns, wire_bytes=len(data)
        )

    def handle(self, op: dict[str, Any], *, recv_ns: int, wire_bytes: int) -> list[Event]:
        """Read a decoded op into its `schemas.ops` model and route it; returns the events.

        Raises :class:`ProtocolError` naming the op and field when the op cannot be read
        (`clients.inbound` says how leniently); an op no handler takes is `Ignored`.
        """
        route = _ROUTES.get(op["op"])
        if route is None:
            return [Ignored(op["op"], "no handler for this op")]
        try:
            return route.run(self, op, recv_ns, wire_bytes)
        except OpError as exc:
            raise ProtocolError(str(exc)) from None

    def _on_publish(self, op: ops.PublishFields, recv_ns: int, wire_bytes: int) -> list[Event]:
        sub_ids = self._topic_index.get(op.topic, ())
        if not sub_ids:
            return [Ignored("publish", f"no subscription for {op.topic}")]
        return [TopicMessage(sub_ids, Received(op.topic, op.msg, recv_ns, wire_bytes))]

    def _on_service_response(self, op: ops.ServiceResponse, _ns: int, _wb: int) -> list[Event]:
        call_id = op.id
        if not isinstance(call_id, str) or call_id not in self._calls:
            return [Ignored("service_response", f"no pending call with id {call_id!r}")]
        service = self._calls.pop(call_id)
        return [ServiceReply(call_id, op.service or service, op.result, op.values)]

    def _on_call_service(self, op: ops.CallService, _ns: int, _wb: int) -> list[Event]:
        if op.service not in self._services:
            return [Ignored("call_service", f"service {op.service} is not advertised here")]
        return [ServiceRequest(op.id, op.service, op.args or {})]

    def _on_action_feedback(self, op: ops.ActionFeedback, _ns: int, _wb: int) -> list[Event]:
        goal_id = op.id
        if not isinstance(goal_id, str) or goal_id not in self._goals:
            return [Ignored("action_feedback", f"no goal with id {goal_id!r}")]
        return [ActionFeedback(goal_id, self._goals[goal_id], op.values)]

    def _on_action_result(self, op: ops.ActionResult, _ns: int, _wb: int) -> list[Event]:
        goal_id = op.id
        if not isinstance(goal_id, str) or goal_id not in self._goals:
            return [Ignored("action_result", f"no goal with id {goal_id!r}")]
        action = self._goals.pop(goal_id)
        return [ActionOutcome(goal_id, action, op.status, op.result, op.values)]

    def _on_goal_request(self, op: ops.SendActionGoal, _ns: int, _wb: int) -> list[Event]:
        if op.action not in self._actions:
            return [Ignored("send_action_goal", f"action {op.action} is not advertised here")]
        goal_id = _goal_id(op)
        return [GoalRequest(goal_id, op.action, op.action_type or None, op.args or {})]

    def _on_goal_cancel(self, op: ops.CancelActionGoal, _ns: int, _wb: int) -> list[Event]:
        return [GoalCancel(_goal_id(op), op.action)]

    def _on_fragment(self, op: ops.Fragment, recv_ns: int, wire_bytes: int) -> list[Event]:
        whole = self._fragments.add(op, wire_bytes)
        if whole is None:
            return []
        inner = self.decode(whole.text, recv_ns=recv_ns)
        return self.handle(inner, recv_ns=recv_ns, wire_bytes=whole.wire_bytes)

    def _on_status(self, op: ops.Status, _ns: int, _wb: int) -> list[Event]:
        return [Ignored("status", f"{op.level}: {op.msg} (id {op.id})")]


#: The ops a server sends a client, each read by its model and handled by one method.
_ROUTES: Mapping[str, OpRoute[ClientProtocol]] = MappingProxyType(
    {
        "publish": Route(ops.parse_publish, ClientProtocol._on_publish),
        **route(ops.ServiceResponse, ClientProtocol._on_service_response),
        **route(ops.CallService, ClientProtocol._on_call_service),
        **route(ops.ActionFeedback, ClientProtocol._on_action_feedback),
        **route(ops.ActionResult, ClientProtocol._on_action_result),
        **route(ops.SendActionGoal, ClientProtocol._on_goal_request),
        **route(ops.CancelActionGoal, ClientProtocol._on_goal_cancel),
        **route(ops.Fragment, ClientProtocol._on_fragment),
        **route(ops.Status, ClientProtocol._on_status),
    }
)


def _goal_id(op: ops.SendActionGoal | ops.CancelActionGoal) -> str:
    """A goal's id: always a string from rosbridge (``action_goal:<action>:<n>``)."""
    if not isinstance(op.id, str):
        raise ProtocolError(f"{op.op} needs a string id, got {op.id!r}")
    return op.id


def _advertise_frame(record: AdvertiseRecord) -> Frame:
    return op_frame(
        ops.Advertise,
        id=record.advert_id,
        type=record.type,
        topic=record.topic,
        latch=record.latch,
        queue_size=record.queue_size,
    )


class _CallOptions(TypedDict, total=False):
    """`call_service` fields sent only when given (after the others, as always)."""

    type: str
    timeout: float


class _SubscribeType(TypedDict, total=False):
    """A `subscribe` names its type and fragment size only when the caller gave one
    (roslibpy sends null)."""

    type: str
    fragment_size: int
    reduce: dict[str, Any]


def _subscribe_frame(record: SubscriptionRecord) -> Frame:
    typed: _SubscribeType = {} if record.type is None else {"type": record.type}
    if record.fragment_size is not None:
        typed["fragment_size"] = record.fragment_size
    if record.reduce is not None:
        typed["reduce"] = dict(record.reduce)
    return op_frame(
        ops.Subscribe,
        id=record.sub_id,
        topic=record.topic,
        compression=record.compression,
        throttle_rate=record.throttle_rate_ms,
        queue_length=record.queue_length,
        **typed,
    )
