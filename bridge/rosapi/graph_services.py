"""rosapi services about the graph: topics, services, nodes, publishers, actions, time."""

from __future__ import annotations

from bridge.context import Context
from bridge.errors import InvalidNameError, RosapiError
from bridge.graph import BRIDGE_NODE, ROSAPI_NODE
from bridge.names import absolute_name
from bridge.rosapi.common import table, text_arg
from schemas.errors import SchemaError
from schemas.typenames import TypeKind, normalize_type_name
from schemas.values import Message

PREFIX = "/rosapi"
NS_PER_S = 1_000_000_000


def name_arg(request: Message, field: str) -> str:
    """An absolute graph name from a request field ("" stays "")."""
    raw = text_arg(request, field)
    try:
        return absolute_name(raw) if raw else ""
    except InvalidNameError as exc:
        raise RosapiError(str(exc)) from exc


def type_arg(request: Message, kind: TypeKind) -> str:
    raw = text_arg(request, "type")
    try:
        return normalize_type_name(raw, kind)
    except SchemaError as exc:
        raise RosapiError(str(exc)) from exc


def topics(ctx: Context, request: Message) -> Message:
    entries = ctx.state.graph.typed_topics()
    return {"topics": [name for name, _ in entries], "types": [t for _, t in entries]}


def topics_for_type(ctx: Context, request: Message) -> Message:
    wanted = type_arg(request, "msg")
    return {"topics": [name for name, t in ctx.state.graph.typed_topics() if t == wanted]}


def full_text(ctx: Context, type_name: str) -> str:
    try:
        return ctx.state.registry.full_text(type_name)
    except SchemaError as exc:
        return f"# failed to get full definition text for {type_name}: {exc}"


def topics_and_raw_types(ctx: Context, request: Message) -> Message:
    entries = ctx.state.graph.typed_topics()
    return {
        "topics": [name for name, _ in entries],
        "types": [t for _, t in entries],
        "typedefs_full_text": [full_text(ctx, t) for _, t in entries],
    }


def service_names(ctx: Context) -> list[str]:
    return sorted([*ctx.state.rosapi, *ctx.state.graph.services])


def service_type_of(ctx: Context, name: str) -> str:
    if name in ctx.state.rosapi:
        return ctx.state.rosapi[name].type_name
    entry = ctx.state.graph.services.get(name)
    return entry.type_name or "" if entry is not None else ""


def services(ctx: Context, request: Message) -> Message:
    return {"services": service_names(ctx)}


def services_for_type(ctx: Context, request: Message) -> Message:
    wanted = type_arg(request, "srv")
    return {"services": [s for s in service_names(ctx) if service_type_of(ctx, s) == wanted]}


def service_type(ctx: Context, request: Message) -> Message:
    return {"type": service_type_of(ctx, name_arg(request, "service"))}


def topic_type(ctx: Context, request: Message) -> Message:
    entry = ctx.state.graph.topics.get(name_arg(request, "topic"))
    return {"type": entry.type_name or "" if entry is not None else ""}


def client_nodes(ctx: Context) -> list[str]:
    return [s.node for s in ctx.state.sessions.values()]


def known_nodes(ctx: Context) -> set[str]:
    """The bridge's nodes, its clients, and every node another middleware (a DDS domain)
    knows: announced ones and those owning a topic's publisher or subscriber."""
    graph = ctx.state.graph
    owners = {node for t in graph.topics.values() for node in (*t.publishers, *t.subscribers)}
    return {BRIDGE_NODE, ROSAPI_NODE, *client_nodes(ctx), *ctx.state.external_nodes, *owners}


def nodes(ctx: Context, request: Message) -> Message:
    return {"nodes": sorted(known_nodes(ctx))}


def provider_of(ctx: Context, service: str) -> str:
    if service in ctx.state.rosapi:
        return ROSAPI_NODE
    entry = ctx.state.graph.services.get(service)
    return entry.provider if entry is not None else ""


def node_details(ctx: Context, request: Message) -> Message:
    node = name_arg(request, "node")
    if node not in known_nodes(ctx):
        raise RosapiError(f"Node {node} does not exist")
    publishing, subscribing = ctx.state.graph.node_topics(node)
    provided = [s for s in service_names(ctx) if provider_of(ctx, s) == node]
    return {"subscribing": subscribing, "publishing": publishing, "services": provided}


def publishers(ctx: Context, request: Message) -> Message:
    entry = ctx.state.graph.topics.get(name_arg(request, "topic"))
    return {"publishers": sorted(entry.publishers) if entry is not None else []}


def subscribers(ctx: Context, request: Message) -> Message:
    entry = ctx.state.graph.topics.get(name_arg(request, "topic"))
    return {"subscribers": sorted(entry.subscribers) if entry is not None else []}


def service_providers(ctx: Context, request: Message) -> Message:
    node = provider_of(ctx, name_arg(request, "service"))
    return {"providers": [node] if node else []}


def service_node(ctx: Context, request: Message) -> Message:
    return {"node": provider_of(ctx, name_arg(request, "service"))}


def action_servers(ctx: Context, request: Message) -> Message:
    return {"action_servers": sorted(ctx.state.graph.actions)}


def action_type(ctx: Context, request: Message) -> Message:
    entry = ctx.state.graph.actions.get(name_arg(request, "action"))
    return {"type": entry.type_name or "" if entry is not None else ""}


def get_time(ctx: Context, request: Message) -> Message:
    sec, nanosec = divmod(ctx.now_ns, NS_PER_S)
    return {"time": {"sec": sec, "nanosec": nanosec}}


def get_ros_version(ctx: Context, request: Message) -> Message:
    return {"version": 2, "distro": ctx.state.config.distro}


SERVICES = table(
    PREFIX,
    {
        "topics": ("Topics", topics),
        "topics_for_type": ("TopicsForType", topics_for_type),
        "topics_and_raw_types": ("TopicsAndRawTypes", topics_and_raw_types),
        "services": ("Services", services),
        "services_for_type": ("ServicesForType", services_for_type),
        "service_type": ("ServiceType", service_type),
        "topic_type": ("TopicType", topic_type),
        "nodes": ("Nodes", nodes),
        "node_details": ("NodeDetails", node_details),
        "publishers": ("Publishers", publishers),
        "subscribers": ("Subscribers", subscribers),
        "service_providers": ("ServiceProviders", service_providers),
        "service_node": ("ServiceNode", service_node),
        "action_servers": ("ActionServers", action_servers),
        "action_type": ("ActionType", action_type),
        "get_time": ("GetTime", get_time),
        "get_ros_version": ("GetROSVersion", get_ros_version),
    },
)
