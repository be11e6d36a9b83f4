"""advertise, unadvertise, publish, subscribe, unsubscribe (protocol §2.1-2.5, §5, §6)."""

from __future__ import annotations

from dataclasses import replace

from bridge.context import Context
from bridge.errors import GraphConflictError, OpFailure
from bridge.graph import TopicEntry
from bridge.names import absolute_name, allowed
from bridge.ops import Route, route
from bridge.outgoing import JSON, MIN_FRAGMENT_SIZE, PNG, TopicMessage
from bridge.reduction import POINTCLOUD2, ReduceRequest
from bridge.session import ClientSession, StatusLevel
from bridge.subscription import SubscribeSettings, Subscription
from bridge.validation import CheckedMessage, InvalidMessage, check_message
from schemas.codec_png import PNG_NEEDS, png_available
from schemas.errors import SchemaError
from schemas.message import has_ros1_header_seq
from schemas.ops import (
    Advertise,
    PublishFields,
    Subscribe,
    Unadvertise,
    Unsubscribe,
    parse_publish,
)
from schemas.specs import MessageSpec


def topic_name(ctx: Context, raw: str) -> str:
    """Absolute topic name, refused if outside `--topics-glob`."""
    name = absolute_name(raw)
    if not allowed(name, ctx.state.config.topics_glob):
        raise OpFailure(f"topic {name} is not allowed by topics_glob")
    return name


def message_type(ctx: Context, raw: str) -> str:
    """Canonical `pkg/msg/Type` of a registered message type, else OpFailure."""
    try:
        return ctx.state.registry.message(raw).name
    except SchemaError as exc:
        raise OpFailure(str(exc)) from exc


def declare(ctx: Context, name: str, type_name: str) -> None:
    try:
        ctx.state.graph.declare_type(name, type_name)
    except GraphConflictError as exc:
        raise OpFailure(str(exc)) from exc


def handle_advertise(ctx: Context, session: ClientSession, op: Advertise) -> None:
    name = topic_name(ctx, op.topic)
    declare(ctx, name, message_type(ctx, op.type))
    entry = ctx.state.graph.add_publisher(name, session.node, op.id, op.latch)
    if op.qos:
        entry.qos[session.node] = op.qos
    session.published.add(name)


def handle_unadvertise(ctx: Context, session: ClientSession, op: Unadvertise) -> None:
    name = topic_name(ctx, op.topic)
    ctx.state.graph.remove_publisher(name, session.node, op.id, every_id=op.id is None)
    entry = ctx.state.graph.topics.get(name)
    if entry is None or session.node not in entry.publishers:
        session.published.discard(name)


ROS1_SEQ_NOTE = (
    "header.seq is ROS 1's (a ROS 2 Header has none): dropped, in this client's later messages too"
)


def handle_publish(ctx: Context, session: ClientSession, op: PublishFields) -> None:
    name = topic_name(ctx, op.topic)
    entry, type_name = publishing_entry(ctx, session, name, op)
    checked = checked_message(ctx, ctx.state.registry.message(type_name), op)
    if isinstance(checked, InvalidMessage):
        raise OpFailure(f"message dropped: {checked.problem}")
    if (
        not session.ros1_seq_noted
        and "header" in checked.spec.by_name  # (valid: the message has no other fields)
        and has_ros1_header_seq(op.msg)
    ):
        session.ros1_seq_noted = True
        ctx.problem(session, "publish", op.id, ROS1_SEQ_NOTE, StatusLevel.WARNING)
    message = TopicMessage(
        name,
        checked.spec.name,
        checked.msg,
        ctx.now_ns,
        ctx.state.registry,
        size_hint=checked.size_hint,
        cdr_bytes=checked.cdr_bytes,
        has_float32=checked.spec.has_float32_sequence,
    )
    if session.node in entry.latching:
        entry.latched = message
    ctx.publish(message, session.node)


def publishing_entry(
    ctx: Context, session: ClientSession, name: str, op: PublishFields
) -> tuple[TopicEntry, str]:
    """The topic `op` publishes on and its type, with the client among its publishers."""
    graph = ctx.state.graph
    if op.type is not None:
        declare(ctx, name, message_type(ctx, op.type))
    entry = graph.topics.get(name)
    if entry is None or entry.type_name is None:
        raise OpFailure(f"Cannot infer topic type for topic {name} as it is not yet advertised")
    if session.node not in entry.publishers:
        graph.add_publisher(name, session.node, op.id, op.latch)
        session.published.add(name)
    elif op.latch:
        entry.latching.add(session.node)
    return entry, entry.type_name


def checked_message(ctx: Context, spec: MessageSpec, op: PublishFields) -> CheckedMessage:
    """The message of `op` checked against `spec`: the check its frame brought from a worker
    (`BridgeCore.offload`) if it was against this very type, else one made now."""
    frame = ctx.frame
    if frame is not None and frame.checked is not None and frame.checked.spec is spec:
        return frame.checked
    return check_message(
        spec, op.msg, wire_bytes=frame.wire_bytes if frame else 0, now_ns=ctx.now_ns
    )


def subscribe_settings(op: Subscribe) -> SubscribeSettings:
    fragment_size = op.fragment_size if op.fragment_size and op.fragment_size > 0 else None
    try:
        reduce = None if op.reduce is None else ReduceRequest.from_op(op.reduce)
    except ValueError as exc:
        raise OpFailure(str(exc)) from None
    return SubscribeSettings(
        reduce=reduce,
        throttle_ms=max(0, op.throttle_rate),
        queue_length=max(0, op.queue_length),
        fragment_size=None if fragment_size is None else max(fragment_size, MIN_FRAGMENT_SIZE),
        compression=SubscribeSettings.known_compression(op.compression),
    )


def handle_subscribe(ctx: Context, session: ClientSession, op: Subscribe) -> None:
    name = topic_name(ctx, op.topic)
    graph = ctx.state.graph
    if op.type is not None:
        declare(ctx, name, message_type(ctx, op.type))
    entry = graph.topics.get(name)
    if entry is None or entry.type_name is None:
        raise OpFailure(f"Cannot infer topic type for topic {name} as it is not yet advertised")
    subscription = session.subscriptions.get(name)
    is_new = subscription is None
    if subscription is None:
        subscription = session.subscriptions[name] = Subscription(name, op.topic)
        ctx.state.topic_subscriptions.setdefault(name, {})[session.client_id] = subscription
        graph.add_subscriber(name, session.node)
    subscription.spelling = op.topic
    if op.qos:
        entry.subscriber_qos[session.node] = op.qos
    settings = subscribe_settings(op)
    if settings.reduce is not None and entry.type_name not in POINTCLOUD2:
        ctx.problem(
            session,
            "subscribe",
            op.id,
            f"reduce applies to sensor_msgs/msg/PointCloud2, not {entry.type_name}; ignored",
            StatusLevel.WARNING,
        )
        settings = replace(settings, reduce=None)
    if settings.compression == PNG and not png_available():
        ctx.problem(session, "subscribe", op.id, f"{PNG_NEEDS}; sending JSON", StatusLevel.WARNING)
        settings = replace(settings, compression=JSON)
    subscription.set_id(op.id, settings)
    if is_new and entry.latched is not None:
        ctx.release(session, subscription, subscription.offer(entry.latched, ctx.now_ns))
    else:
        ctx.release(session, subscription, subscription.release(ctx.now_ns))


def handle_unsubscribe(ctx: Context, session: ClientSession, op: Unsubscribe) -> None:
    name = absolute_name(op.topic)
    subscription = session.subscriptions.get(name)
    if subscription is None:
        return
    if op.id is None:
        subscription.ids.clear()
    else:
        subscription.remove_id(op.id)
    if not subscription.ids:
        drop_subscription(ctx, session, name)
    else:
        ctx.release(session, subscription, subscription.release(ctx.now_ns))


def drop_subscription(ctx: Context, session: ClientSession, name: str) -> None:
    """Forget the client's subscription to `name` and its place in the graph."""
    session.subscriptions.pop(name, None)
    by_client = ctx.state.topic_subscriptions.get(name, {})
    by_client.pop(session.client_id, None)
    if not by_client:
        ctx.state.topic_subscriptions.pop(name, None)
    ctx.state.graph.remove_subscriber(name, session.node)


def release_client(ctx: Context, session: ClientSession) -> None:
    """Disconnect clean-up: every subscription and advertisement of the client."""
    for name in list(session.subscriptions):
        drop_subscription(ctx, session, name)
    for name in list(session.published):
        ctx.state.graph.remove_publisher(name, session.node)
    session.published.clear()


def on_release_deadline(ctx: Context, client_id: int, topic: str) -> None:
    """A throttled subscription's next queued message may leave now."""
    session = ctx.state.sessions.get(client_id)
    subscription = session.subscriptions.get(topic) if session else None
    if session is not None and subscription is not None:
        ctx.release(session, subscription, subscription.release(ctx.now_ns))


ROUTES = (
    route(Advertise, handle_advertise),
    route(Unadvertise, handle_unadvertise),
    Route("publish", parse_publish, handle_publish),  # the fast reader of the busiest op
    route(Subscribe, handle_subscribe),
    route(Unsubscribe, handle_unsubscribe),
)
