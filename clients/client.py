"""The asyncio rosbridge client: a thin pump around :class:`clients.protocol.ClientProtocol`.

It owns the socket, the clock, the worker threads and the reconnect loop; every protocol rule
lives in the sans-I/O core. Typical use::

    async with RosbridgeClient("ws://127.0.0.1:9090") as client:
        await client.advertise("/imu", "sensor_msgs/msg/Imu")
        await client.publish("/imu", imu_msg)
        sub = await client.subscribe("/cloud", "sensor_msgs/msg/PointCloud2")
        async for item in sub:           # clients.Received
            ...
        values = await client.call_service("/rosapi/topics")

Concurrency: all methods are coroutines for one event loop and may be called concurrently from
many tasks of that loop (publishing several topics while a service call is waiting is the
normal case). The client is not thread-safe: use it from the loop that connected it.

Data path (DESIGN §4): payloads whose encode or decode would hold the loop for more than about
a millisecond (``offload_bytes``) are encoded and decoded on worker threads (one for each
direction, so order is kept), leaving the loop free for small messages; compression is off
and ``max_size`` raised on the websocket.
"""

from __future__ import annotations

import asyncio
import logging
import random
import time
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from types import MappingProxyType
from typing import Any

from websockets.asyncio.client import ClientConnection

from clients.action_server import ActionHandler, ActionHost
from clients.actions import ActionGoal
from clients.backoff import BackoffPolicy
from clients.connection import TransportConfig, open_with_retry, translate_transport_error
from clients.errors import ClientClosed, ConnectionClosed, ServiceError
from clients.events import (
    ActionFeedback,
    ActionOutcome,
    Event,
    GoalCancel,
    GoalRequest,
    Ignored,
    ServiceReply,
    ServiceRequest,
    TopicMessage,
)
from clients.protocol import DEFAULT_QUEUE_SIZE, ClientProtocol, Compression, Encoding
from clients.publisher import PublishStats, TopicPublisher
from clients.reader import FramePump
from clients.services import Handler, ServiceHost, normalize_service_values
from clients.subscription import DEFAULT_MAXSIZE, Subscription
from clients.tracing import Tracer
from clients.wire import Frame
from schemas.message import payload_bytes
from schemas.registry import TypeRegistry

logger = logging.getLogger(__name__)

OFFLOAD_BYTES: Mapping[str, int] = MappingProxyType({"json": 256 * 1024, "cbor": 8 * 1024 * 1024})
"""Payloads from this size on are encoded/decoded on a worker thread. The budget is ~1 ms of
event-loop time per message: JSON+base64 costs ~4-8 ms per MB (256 KB ≈ 1 ms), CBOR ~0.1-0.25
ms per MB (reference/performance-measurements.md; measured here: 4 MiB cloud 0.5 ms encode,
0.7 ms decode), so a CBOR scan stays on the loop, where a thread hop would cost more than the
encode (measured: LIDAR median 9 ms inline against 13 ms offloaded through a relay)."""


class RosbridgeClient:
    """One rosbridge v2 connection with automatic reconnect.

    url : ``ws://host:port``.
    encoding : "cbor" (default) publishes binary CBOR frames and subscribes with
        ``compression="cbor"``; "json" uses JSON text everywhere (any rosbridge server).
    name : used in log lines and worker-thread names.
    connect_timeout : seconds ``connect()`` keeps retrying before :class:`ConnectionFailed`.
    reconnect : after a lost connection, reconnect forever (backoff ``backoff_initial`` ..
        ``backoff_max`` seconds) and restore advertisements, services and subscriptions.
    registry : message types for normalizing typed subscriptions; a default one if omitted.
    offload_bytes : payload size from which encode/decode run on worker threads; the default
        depends on the encoding (:data:`OFFLOAD_BYTES`).
    tracer : records ``encode``/``send``/``decode`` spans of stamped messages
        (:mod:`clients.tracing`, docs/tracing.md); None records nothing.
    """

    def __init__(
        self,
        url: str,
        *,
        encoding: Encoding = "cbor",
        name: str = "rosbridge-client",
        connect_timeout: float = 10.0,
        reconnect: bool = True,
        backoff_initial: float = 0.1,
        backoff_max: float = 2.0,
        registry: TypeRegistry | None = None,
        offload_bytes: int | None = None,
        transport: TransportConfig | None = None,
        tracer: Tracer | None = None,
    ) -> None:
        self.url = url
        self.tracer = tracer
        self.name = name
        self._registry = registry if registry is not None else TypeRegistry.with_defaults()
        self._protocol = ClientProtocol(encoding=encoding, spec_lookup=self._registry.message)
        self._connect_timeout_s = connect_timeout
        self._reconnect = reconnect
        self._backoff = BackoffPolicy(initial_s=backoff_initial, max_s=backoff_max)
        self._transport = transport or TransportConfig()
        self._offload_bytes = offload_bytes or OFFLOAD_BYTES[encoding]
        self._rng = random.Random()
        self._ws: ClientConnection | None = None
        self._run_task: asyncio.Task[None] | None = None
        self._closed = False
        self._connected = asyncio.Event()
        self._subs: dict[str, Subscription] = {}
        self._calls: dict[str, asyncio.Future[ServiceReply]] = {}
        self._goals: dict[str, ActionGoal] = {}
        self._services = ServiceHost(self._registry, self._send)
        self._action_host = ActionHost(self._registry, self._send)
        self._publishers: dict[str, TopicPublisher] = {}
        # latched topic -> its last message, re-sent on every new connection (a restarted
        # bridge has forgotten it, and late subscribers such as tf listeners need it)
        self._latched: dict[str, dict[str, Any] | None] = {}
        self._encode_pool = ThreadPoolExecutor(1, thread_name_prefix=f"{name}-encode")
        self._decode_pool = ThreadPoolExecutor(1, thread_name_prefix=f"{name}-decode")
        self._pump = FramePump(
            self._protocol,
            decode_pool=self._decode_pool,
            offload_bytes=self._offload_bytes,
            deliver=self._deliver,
            on_bad_frame=self._bad_frame,
        )
        self.connections = 0
        """Successful connections so far (1 after connect, +1 per reconnect)."""
        self.bad_frames = 0
        """Incoming frames that could not be decoded or routed (each logged)."""

    # ------------------------------------------------------------------ lifecycle
    @property
    def encoding(self) -> Encoding:
        """The connection encoding, "cbor" or "json"."""
        return self._protocol.encoding

    @property
    def is_connected(self) -> bool:
        """True while a websocket is open."""
        return self._ws is not None

    async def connect(self) -> None:
        """Connect, retrying with backoff for up to ``connect_timeout`` seconds.

        Raises :class:`ConnectionFailed`. Calling it again while connected does nothing.
        """
        if self._closed:
            raise ClientClosed(f"{self.name} is closed")
        if self._run_task is not None and not self._run_task.done():
            return
        ws = await open_with_retry(
            self.url, self._transport, self._backoff, self._rng, timeout_s=self._connect_timeout_s
        )
        await self._attach(ws)
        self._run_task = asyncio.create_task(self._run(ws), name=f"{self.name} reader")
        self._run_task.add_done_callback(self._on_run_done)

    async def wait_connected(self, timeout: float | None = None) -> None:
        """Wait until a connection is open (e.g. after a bridge restart); ``TimeoutError``."""
        async with asyncio.timeout(timeout):
            await self._connected.wait()

    async def close(self) -> None:
        """Close the connection and end every subscription, call and goal. Idempotent."""
        if self._closed:
            return
        self._closed = True
        for publisher in self._publishers.values():
            publisher.cancel()
        if self._run_task is not None:
            self._run_task.cancel()
            await asyncio.gather(self._run_task, return_exceptions=True)
        await self._services.cancel_all()
        await self._action_host.cancel_all()
        if self._ws is not None:
            try:
                with translate_transport_error("close"):
                    await self._ws.close()
            except ConnectionClosed as exc:
                logger.debug("%s: %s", self.name, exc)
        self._detach(ClientClosed(f"{self.name} closed"))
        for sub in self._subs.values():
            sub.finish(ClientClosed(f"{self.name} closed"))
        self._encode_pool.shutdown(wait=False, cancel_futures=True)
        self._decode_pool.shutdown(wait=False, cancel_futures=True)

    async def __aenter__(self) -> RosbridgeClient:
        await self.connect()
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.close()

    # ------------------------------------------------------------------- topics
    async def advertise(
        self,
        topic: str,
        type: str,
        *,
        latch: bool = False,
        queue_size: int = DEFAULT_QUEUE_SIZE,
        latest_only: bool = False,
    ) -> None:
        """Declare that we publish ``topic`` of ``type`` (re-sent after every reconnect).

        latest_only : keep at most one unsent message for this topic; a newer ``publish``
            replaces it and ``publish`` never waits for the socket (see
            :mod:`clients.publisher`). For high-rate sensor streams where stale data is useless.
        """
        frame = self._protocol.advertise(topic, type, latch=latch, queue_size=queue_size)
        self._publisher(topic).latest_only = latest_only
        if latch:
            self._latched.setdefault(topic, None)
        await self._send_control(frame)

    async def unadvertise(self, topic: str) -> None:
        """Withdraw an advertisement made with :meth:`advertise`."""
        self._latched.pop(topic, None)
        frame = self._protocol.unadvertise(topic)
        if frame is not None:
            await self._send_control(frame)

    async def publish(self, topic: str, msg: dict[str, Any]) -> None:
        """Send one message (canonical form: bytes, ndarrays, dicts) on ``topic``.

        While the client is reconnecting the message is dropped and counted
        (``publish_stats(topic).dropped_disconnected``): sensor data is not worth replaying
        late. Without ``reconnect`` a closed connection raises :class:`ConnectionClosed`.
        """
        publisher = self._publisher(topic)
        if topic in self._latched:
            self._latched[topic] = msg
        try:
            if self._ws is None:
                raise self._not_connected("publish")
            await publisher.publish(msg)
        except ConnectionClosed:
            if self._closed or not self._reconnect or self._run_task is None:
                raise
            publisher.count_disconnected()

    @property
    def dropped(self) -> int:
        """Messages this client dropped: full subscription queues, stale or unsendable
        publishes."""
        received = sum(sub.dropped for sub in self._subs.values())
        sent = sum(
            p.stats.dropped_stale + p.stats.dropped_disconnected for p in self._publishers.values()
        )
        return received + sent

    def publish_stats(self, topic: str) -> PublishStats:
        """Counters of ``topic``'s send path (zeros for a topic never published)."""
        publisher = self._publishers.get(topic)
        return publisher.stats if publisher is not None else PublishStats()

    async def flush(self) -> None:
        """Wait until every latest-only topic has sent its parked message."""
        await asyncio.gather(*(p.flush() for p in list(self._publishers.values())))

    async def subscribe(
        self,
        topic: str,
        type: str | None = None,
        *,
        throttle_rate: int = 0,
        queue_length: int = 0,
        compression: Compression | None = None,
        maxsize: int = DEFAULT_MAXSIZE,
        bytes_as_numpy: bool = False,
        fragment_size: int | None = None,
        reduce: Mapping[str, Any] | None = None,
    ) -> Subscription:
        """Subscribe to ``topic``; returns an async iterator of :class:`clients.Received`.

        type : message type; when given, messages arrive in canonical form (JSON base64 ->
            bytes, lists -> ndarrays, defaults filled). Unknown types raise SchemaError here.
        throttle_rate : minimum milliseconds between messages, applied by the bridge.
        queue_length : while the link cannot take more, the bridge keeps only this many newest
            messages (0: every message, within its send buffer).
        compression : "none", "png", "cbor", "cbor-raw"; default follows the encoding.
        maxsize : local queue length; when full the oldest message is dropped and counted.
        bytes_as_numpy : deliver ``bytes`` fields as read-only uint8 ndarray views.
        fragment_size : the bridge cuts larger messages into fragments this long, sent with
            other topics' messages between them (docs/bridge.md, "Over a thin link").
        reduce : a PointCloud2 thinned by the bridge: ``{"voxel_size": m}``,
            ``{"point_budget": n}`` or ``{"point_budget": "auto"}`` (what the link carries).

        Works before the topic has a publisher, before ``connect()`` and while reconnecting
        (the subscription is then sent when the connection opens).
        """
        sub_id, frame = self._protocol.subscribe(
            topic,
            type,
            throttle_rate_ms=throttle_rate,
            queue_length=queue_length,
            compression=compression,
            fragment_size=fragment_size,
            reduce=reduce,
        )
        sub = Subscription(
            topic=topic,
            sub_id=sub_id,
            type=type,
            maxsize=maxsize,
            bytes_as_numpy=bytes_as_numpy,
            unsubscribe=self._unsubscribe,
        )
        self._subs[sub_id] = sub
        await self._send_control(frame)
        return sub

    async def _unsubscribe(self, sub: Subscription) -> None:
        self._subs.pop(sub.id, None)
        frame = self._protocol.unsubscribe(sub.id)
        if frame is not None and not self._closed:
            await self._send_control(frame)

    # ------------------------------------------------------------------ services
    async def call_service(
        self,
        service: str,
        args: dict[str, Any] | None = None,
        *,
        type: str | None = None,
        timeout: float | None = 5.0,
    ) -> Any:
        """Call a service and return its response ``values``.

        With ``type`` (``pkg/srv/T``) known to the registry, the values come normalized.
        Raises :class:`ServiceError` on ``result: false``, ``TimeoutError`` after ``timeout``
        seconds, :class:`ConnectionClosed` if not connected or the connection drops meanwhile.
        """
        if self._ws is None:
            raise self._not_connected(f"call {service}")
        call_id, frame = self._protocol.call_service(service, args, type=type, timeout_s=timeout)
        reply: asyncio.Future[ServiceReply] = asyncio.get_running_loop().create_future()
        self._calls[call_id] = reply
        try:
            await self._send(frame)
            async with asyncio.timeout(timeout):
                answer = await reply
        finally:
            self._calls.pop(call_id, None)
            self._protocol.forget_call(call_id)
        if not answer.result:
            raise ServiceError(answer.values, service=service)
        return normalize_service_values(self._registry, type, "response", answer.values)

    async def advertise_service(self, service: str, type: str, handler: Handler) -> None:
        """Provide ``service``: ``async def handler(args) -> dict`` answers each call.

        ``args`` are normalized when ``type`` is known to the registry. A handler exception
        is answered as ``result: false`` with its message. Handlers of concurrent calls run
        concurrently. Re-advertised automatically after a reconnect.
        """
        self._services.add(service, type, handler)
        await self._send_control(self._protocol.advertise_service(service, type))

    async def unadvertise_service(self, service: str) -> None:
        """Stop providing ``service``."""
        self._services.remove(service)
        frame = self._protocol.unadvertise_service(service)
        if frame is not None:
            await self._send_control(frame)

    # ------------------------------------------------------------------- actions
    async def send_action_goal(
        self, action: str, action_type: str, args: dict[str, Any] | None = None
    ) -> ActionGoal:
        """Send a goal to an action server; returns its :class:`ActionGoal` handle."""
        if self._ws is None:
            raise self._not_connected(f"send a goal to {action}")
        goal_id, frame = self._protocol.send_action_goal(action, action_type, args)
        goal = ActionGoal(goal_id, action, action_type, self._registry, self._cancel_goal)
        self._goals[goal_id] = goal
        try:
            await self._send(frame)
        except ConnectionClosed:
            self._goals.pop(goal_id, None)
            self._protocol.forget_goal(goal_id)
            raise
        return goal

    async def advertise_action(self, action: str, type: str, handler: ActionHandler) -> None:
        """Serve ``action``: ``async def handler(args, feedback) -> dict`` runs per goal.

        ``await feedback(values)`` reports progress; the returned dict is the result. A
        caller's cancel cancels the handler's task (answered CANCELED); an exception answers
        ``result: false``. Re-advertised automatically after a reconnect.
        """
        self._action_host.add(action, type, handler)
        await self._send_control(self._protocol.advertise_action(action, type))

    async def unadvertise_action(self, action: str) -> None:
        """Stop serving ``action``."""
        self._action_host.remove(action)
        frame = self._protocol.unadvertise_action(action)
        if frame is not None:
            await self._send_control(frame)

    async def _cancel_goal(self, goal: ActionGoal) -> None:
        frame = self._protocol.cancel_action_goal(goal.id)
        if frame is not None:
            await self._send(frame)

    # ------------------------------------------------------------------ internals
    def _publisher(self, topic: str) -> TopicPublisher:
        publisher = self._publishers.get(topic)
        if publisher is None:
            on_sent = self.tracer.published if self.tracer is not None else None
            publisher = TopicPublisher(
                topic, latest_only=False, encode=self._encode, send=self._send, on_sent=on_sent
            )
            self._publishers[topic] = publisher
        return publisher

    async def _encode(self, topic: str, msg: dict[str, Any]) -> Frame:
        """Encode a publish, on the encode thread when its payload is large."""
        if payload_bytes(msg) < self._offload_bytes:
            return self._protocol.encode_publish(topic, msg)
        loop = asyncio.get_running_loop()
        try:
            return await loop.run_in_executor(
                self._encode_pool, self._protocol.encode_publish, topic, msg
            )
        except RuntimeError as exc:
            if not self._closed:
                raise
            raise self._not_connected(f"publish on {topic}") from exc  # pool shut down

    async def _send(self, frame: Frame) -> None:
        """Write one frame; raises :class:`ConnectionClosed` when there is no connection."""
        ws = self._ws
        if ws is None:
            raise self._not_connected("send")
        with translate_transport_error(f"{self.name} send"):
            await ws.send(frame.data, text=frame.text)

    def _not_connected(self, what: str) -> ConnectionClosed:
        """The error for an operation that needs an open connection and has none."""
        if self._closed:
            return ClientClosed(f"{self.name} is closed; cannot {what}")
        return ConnectionClosed(f"{self.name} is not connected; cannot {what}")

    async def _send_control(self, frame: Frame) -> None:
        """Send a registration op; before ``connect()`` or while reconnecting it is left to
        the resume frames of the next connection instead."""
        try:
            await self._send(frame)
        except ConnectionClosed:
            if self._closed or (not self._reconnect and self.connections > 0):
                raise

    async def _attach(self, ws: ClientConnection) -> None:
        """Adopt a fresh websocket and restore our registrations on it."""
        self._ws = ws
        self.connections += 1
        frames = self._protocol.resume_frames()
        self._connected.set()
        logger.info(
            "%s connected to %s (%d registrations restored)", self.name, self.url, len(frames)
        )
        try:
            for frame in frames:
                await self._send(frame)
            for topic, msg in list(self._latched.items()):
                if msg is not None:
                    await self._publisher(topic).publish(msg)
        except ConnectionClosed as exc:
            logger.warning("%s lost the connection while resuming: %s", self.name, exc)

    def _detach(self, reason: ConnectionClosed) -> None:
        """Forget the websocket and fail everything that waited for an answer on it."""
        self._ws = None
        self._connected.clear()
        calls, goals = self._protocol.connection_lost()
        for call_id in calls:
            reply = self._calls.pop(call_id, None)
            if reply is not None and not reply.done():
                reply.set_exception(reason)
        for goal_id in goals:
            goal = self._goals.pop(goal_id, None)
            if goal is not None:
                goal.fail(reason)

    async def _run(self, ws: ClientConnection) -> None:
        """Read until the connection ends; then reconnect (if asked) and read again."""
        while True:
            await self._pump.run(ws)
            lost = ConnectionClosed(f"{self.name}: connection to {self.url} lost")
            self._detach(lost)
            if not self._reconnect:
                for sub in self._subs.values():
                    sub.finish(lost)
                return
            logger.warning("%s lost its connection to %s; reconnecting", self.name, self.url)
            ws = await open_with_retry(
                self.url, self._transport, self._backoff, self._rng, timeout_s=None
            )
            await self._attach(ws)

    def _on_run_done(self, task: asyncio.Task[None]) -> None:
        """A reader that died of a bug must not leave consumers waiting forever."""
        if task.cancelled() or task.exception() is None:
            return
        logger.error("%s reader failed", self.name, exc_info=task.exception())
        lost = ConnectionClosed(f"{self.name} reader failed: {task.exception()!r}")
        self._detach(lost)
        for sub in self._subs.values():
            sub.finish(lost)

    def _bad_frame(self, exc: Exception) -> None:
        self.bad_frames += 1
        logger.warning("%s dropped a frame from %s: %s", self.name, self.url, exc)

    def _deliver(self, event: Event) -> None:
        """Carry one routed event to its destination (never blocks the reader)."""
        match event:
            case TopicMessage(sub_ids=sub_ids, received=received):
                if self.tracer is not None:
                    self.tracer.received(received, time.time_ns())
                for sub_id in sub_ids:
                    sub = self._subs.get(sub_id)
                    if sub is not None:
                        sub.deliver(received)
            case ServiceReply(call_id=call_id):
                reply = self._calls.get(call_id)
                if reply is not None and not reply.done():
                    reply.set_result(event)
            case ServiceRequest():
                self._services.serve(event)
            case ActionFeedback(goal_id=goal_id):
                if (goal := self._goals.get(goal_id)) is not None:
                    goal.on_feedback(event)
            case ActionOutcome(goal_id=goal_id):
                if (goal := self._goals.pop(goal_id, None)) is not None:
                    goal.on_outcome(event)
            case GoalRequest():
                self._action_host.start(event)
            case GoalCancel():
                self._action_host.cancel(event)
            case Ignored(op=op, reason=reason):
                logger.debug("%s ignored %s: %s", self.name, op, reason)
