"""What every graph mirror (`dds/`, `zenoh/`) does the same way, whatever the middleware.

A mirror joins the bridge's graph to an external one through its `PluginHost`. Which nodes it
speaks for, how often it brings the middleware in step, which topics want a writer or a reader
and with what QoS, and how remote servers' services appear in the bridge (a stand-in client
named like the remote node) do not depend on DDS or Zenoh: they are written here once, and
each mirror supplies only what its middleware does differently.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Container, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from bridge.dds.qos import QosProfile, strongest
from bridge.host import PluginHost
from schemas.values import Message

if TYPE_CHECKING:
    from bridge.dds.discovery import RemoteTopic
    from bridge.graph import TopicEntry

RECONCILE_S = 0.1  # how late a new advertisement or subscription reaches the middleware at most


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


async def reconcile_forever(
    reconcile: Callable[[], None], wake: asyncio.Event, logger: logging.Logger, label: str
) -> None:
    """Call `reconcile` every `RECONCILE_S`, or sooner once `wake` is set, until cancelled; a
    failing reconcile is logged (a bug there must not end the mirror)."""
    while True:
        try:
            reconcile()
        except Exception:
            logger.exception("%s: reconcile failed", label)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(RECONCILE_S):
                await wake.wait()
        wake.clear()
