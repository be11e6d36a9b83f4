"""What every graph mirror (`dds/`, `zenoh/`) does the same way, whatever the middleware.

A mirror joins the bridge's graph to an external one through its `PluginHost`. Which nodes it
speaks for, how often it brings the middleware in step, which topics want a writer or a reader
and with what QoS, how the middleware's requests reach local providers (the mirror's own
client) and how remote servers' services appear in the bridge (a stand-in client named like
the remote node) do not depend on DDS or Zenoh: they are written here once, and each mirror
supplies only what its middleware does differently.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
from collections.abc import Callable, Container, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, Protocol, TypeVar

from bridge.dds.qos import QosProfile, strongest
from bridge.errors import BridgeError
from bridge.host import PluginHost
from bridge.outgoing import ControlMessage
from schemas.errors import SchemaError
from schemas.values import JsonObject, JsonValue, Message

if TYPE_CHECKING:
    from bridge.dds.discovery import RemoteTopic
    from bridge.effects import Send
    from bridge.graph import TopicEntry

RECONCILE_S = 0.1  # how late a new advertisement or subscription reaches the middleware at most

EndpointT = TypeVar("EndpointT")
WaitingT = TypeVar("WaitingT")
# (stand-in client id, the caller's request id, the service as the caller spelt it)
WaitingCall = tuple[int, JsonValue, JsonValue]


@dataclass(frozen=True)
class Wanted:
    """An endpoint a mirror wants for a topic: its ROS type and QoS."""

    type_name: str
    profile: QosProfile


@dataclass(frozen=True)
class Arrival:
    """A checked, decoded sample from the middleware, for the event loop: what, and the GID
    (DDS: GUID) of the remote writer that sent it when the middleware says."""

    topic: str
    type_name: str
    msg: Message
    cdr: bytes
    sender_gid: bytes | None


class Injection:
    """Publishes the middleware's samples into the bridge as their remote node's. `active`
    is True while it does, so that the mirror's own sink, which sees every message the
    bridge publishes, does not send the sample back (no echo)."""

    def __init__(self, host: PluginHost) -> None:
        self._host = host
        self.active = False

    def publish(self, node: str, arrival: Arrival, latch: bool) -> str | None:
        """Publish `arrival` as `node`'s; why the bridge refused it, or None."""
        self.active = True
        try:
            self._host.publish_external(
                node, arrival.topic, arrival.type_name, arrival.msg, arrival.cdr, latch=latch
            )
        except (BridgeError, SchemaError) as exc:
            return str(exc)
        finally:
            self.active = False
        return None


class _Provided(Protocol):
    @property
    def provider(self) -> str | None: ...
    @property
    def type_name(self) -> str | None: ...


def mirrored_nodes(host: PluginHost, own_clients: Container[int], source: str) -> set[str]:
    """Nodes whose endpoints and messages a mirror takes to its middleware: the websocket
    clients' (not the mirror's own in-process clients, `own_clients`) and, as a gateway, those
    other graphs' plug-ins speak for (`PluginHost.gateway_nodes`)."""
    clients = {s.node for s in host.clients().values() if s.client_id not in own_clients}
    return clients | host.gateway_nodes(source)


def provided_by(entries: Mapping[str, _Provided], local: Container[str]) -> dict[str, str]:
    """Name -> type of the services (or actions) in `entries` that `local` nodes provide."""
    return {
        name: entry.type_name
        for name, entry in entries.items()
        if entry.provider in local and entry.type_name
    }


def wanted_topics(
    topics: Iterable[TopicEntry],
    local: Container[str],
    remote: Mapping[str, RemoteTopic],
    advertised: Callable[[TopicEntry, str], QosProfile],
    reading: Callable[[TopicEntry, list[QosProfile]], QosProfile],
    readers_for: Container[str] | None = None,
) -> tuple[dict[str, Wanted], dict[str, Wanted]]:
    """(writers, readers) a mirror wants: a writer per typed topic `local` nodes publish, with
    the strongest of their `advertised` profiles; a reader per typed topic `readers_for` nodes
    (default: `local`) subscribe to, `reading` the profiles the remote writers offer."""
    subscribing = local if readers_for is None else readers_for
    writers: dict[str, Wanted] = {}
    readers: dict[str, Wanted] = {}
    for entry in topics:
        if entry.type_name is None:
            continue
        publishing = [node for node in entry.publishers if node in local]
        if publishing:
            profiles = [advertised(entry, node) for node in publishing]
            writers[entry.name] = Wanted(entry.type_name, strongest(profiles))
        if any(node in subscribing for node in entry.subscribers):
            seen = remote.get(entry.name)
            offered = [p for ps in seen.publishers.values() for p in ps] if seen else []
            readers[entry.name] = Wanted(entry.type_name, reading(entry, offered))
    return writers, readers


class Reconciler:
    """Runs a mirror's `reconcile` every `RECONCILE_S` on the loop, and soon after `wake()`
    (a discovery change, a first message), from `start()` to `stop()`; a failing reconcile is
    logged (a bug there must not end the mirror)."""

    def __init__(self, reconcile: Callable[[], None], logger: logging.Logger, label: str) -> None:
        self._reconcile, self._logger, self._label = reconcile, logger, label
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    def start(self, task_name: str) -> None:
        self._task = asyncio.create_task(self._forever(), name=task_name)

    def wake(self) -> None:
        self._wake.set()

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    async def _forever(self) -> None:
        while True:
            try:
                self._reconcile()
            except Exception:
                self._logger.exception("%s: reconcile failed", self._label)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(RECONCILE_S):
                    await self._wake.wait()
            self._wake.clear()


def control_payload(send: Send) -> JsonObject:
    """The op the core sends an in-process client (empty for a topic message)."""
    return send.item.payload if isinstance(send.item, ControlMessage) else {}


def called_endpoint(clients: Mapping[str, EndpointT], payload: JsonObject) -> EndpointT | None:
    """The endpoint of the service a stand-in's `call_service` names (relative names too)."""
    if payload.get("op") != "call_service":
        return None
    name = payload.get("service")
    return clients.get(name if isinstance(name, str) and name.startswith("/") else f"/{name}")


def waiting_call(send: Send, payload: JsonObject) -> WaitingCall:
    """What answering a stand-in's `call_service` needs later."""
    return (send.client_id, payload.get("id"), payload.get("service"))


class Caller(Generic[WaitingT]):
    """The mirror's own in-process client (its node): a request from the middleware becomes
    its `call_service` to the local provider, and the provider's `service_response` goes to
    `answered` with what `call` was given to remember the request by."""

    def __init__(
        self,
        host: PluginHost,
        node: str,
        peer: str,
        answered: Callable[[WaitingT, JsonObject], None],
    ) -> None:
        self._host, self._peer, self._answered = host, peer, answered
        self.client_id = host.connect_internal(node, self._receives, peer=peer)
        self.waiting: dict[str, WaitingT] = {}
        self._calls = itertools.count(1)

    def call(self, service: str, args: JsonValue, waiting: WaitingT) -> None:
        call_id = f"{self._peer}:{next(self._calls)}"
        self.waiting[call_id] = waiting
        op: JsonObject = {"op": "call_service", "service": service, "args": args, "id": call_id}
        self._host.send_op(self.client_id, op)

    def _receives(self, send: Send) -> None:
        payload = control_payload(send)
        waiting = self.waiting.pop(str(payload.get("id")), None)
        if payload.get("op") == "service_response" and waiting is not None:
            self._answered(waiting, payload)

    def close(self) -> None:
        self.waiting.clear()
        self._host.disconnect_internal(self.client_id)


class StandIns:
    """In-process clients named like remote nodes, which advertise the remote nodes' services
    in the bridge; the core forwards local calls to them (`receive`). One per remote node,
    gone with its last service. `client_ids` holds the mirror's own clients, these included."""

    def __init__(
        self,
        host: PluginHost,
        receive: Callable[[Send], None],
        peer: str,
        client_ids: set[int],
    ) -> None:
        self._host, self._receive, self._peer = host, receive, peer
        self.client_ids = client_ids
        self.by_node: dict[str, int] = {}  # remote node -> its stand-in client id

    def node_is_a_client(self, node: str) -> bool:
        """True if a websocket client has that node name: a stand-in never impersonates it."""
        return any(
            s.node == node
            for s in self._host.clients().values()
            if s.client_id not in self.client_ids
        )

    def advertise(self, node: str, service: str, type_name: str) -> None:
        stand_in = self.by_node.get(node)
        if stand_in is None:
            stand_in = self._host.connect_internal(node, self._receive, peer=self._peer)
            self.by_node[node] = stand_in
            self.client_ids.add(stand_in)
        op: JsonObject = {"op": "advertise_service", "service": service, "type": type_name}
        self._host.send_op(stand_in, op)

    def unadvertise(self, node: str, service: str, node_still_serves: bool) -> bool:
        """Withdraw `service` (which fails the calls still waiting on it); the stand-in goes
        unless `node_still_serves`. False if `node` has no stand-in."""
        stand_in = self.by_node.get(node)
        if stand_in is None:
            return False
        self._host.send_op(stand_in, {"op": "unadvertise_service", "service": service})
        if not node_still_serves:
            del self.by_node[node]
            self.client_ids.discard(stand_in)
            self._host.disconnect_internal(stand_in)
        return True

    def answer(self, waiting: WaitingCall, values: JsonValue, ok: bool) -> None:
        """The `service_response` to a call the core forwarded to a stand-in."""
        stand_in, request_id, spelling = waiting
        if stand_in not in self.client_ids:
            return  # the stand-in went meanwhile: the core failed the call already
        op: JsonObject = {
            "op": "service_response",
            "id": request_id,
            "service": spelling,
            "values": values,
            "result": ok,
        }
        self._host.send_op(stand_in, op)
