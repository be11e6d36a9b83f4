"""The channel and service tables shared by every Foxglove client of one bridge.

A topic gets a channel (`encoding: "cdr"`, `schemaEncoding: "ros2msg"`, the type's full
definition text) while it has a publisher and a type the registry knows; a service gets a
service id while it is provided and its type is known. Ids are never reused, so a client
never confuses a gone channel with a new one. Pure data: `reconcile` takes the graph as it is
now and says what appeared and what went.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from schemas.errors import SchemaError
from schemas.registry import TypeRegistry

CDR = "cdr"
ROS2MSG = "ros2msg"


@dataclass(frozen=True)
class Channel:
    id: int
    topic: str
    type_name: str
    schema: str

    def advert(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "topic": self.topic,
            "encoding": CDR,
            "schemaName": self.type_name,
            "schemaEncoding": ROS2MSG,
            "schema": self.schema,
        }


@dataclass(frozen=True)
class Service:
    id: int
    name: str
    type_name: str
    request_type: str
    response_type: str
    request_schema: str
    response_schema: str

    def advert(self) -> dict[str, Any]:
        def part(type_name: str, schema: str) -> dict[str, str]:
            return {
                "encoding": CDR,
                "schemaName": type_name,
                "schemaEncoding": ROS2MSG,
                "schema": schema,
            }

        return {
            "id": self.id,
            "name": self.name,
            "type": self.type_name,
            "request": part(self.request_type, self.request_schema),
            "response": part(self.response_type, self.response_schema),
            # Older clients read only these (deprecated in the spec, still sent by bridges).
            "requestSchema": self.request_schema,
            "responseSchema": self.response_schema,
        }


@dataclass
class Changes:
    added: list[dict[str, Any]] = field(default_factory=list)
    removed: list[int] = field(default_factory=list)


class ChannelTable:
    """Topics and services as Foxglove ids; `reconcile_*` with the graph's current state."""

    def __init__(self, registry: TypeRegistry) -> None:
        self._registry = registry
        self._ids = itertools.count(1)
        self.by_topic: dict[str, Channel] = {}
        self.by_id: dict[int, Channel] = {}
        self.services_by_name: dict[str, Service] = {}
        self.services_by_id: dict[int, Service] = {}
        self._texts: dict[str, str | None] = {}  # definition text by type (None: unknown)

    def reconcile_topics(self, published: Mapping[str, str]) -> Changes:
        """`published`: topic -> type of every topic with a publisher."""
        changes = Changes()
        for topic, channel in list(self.by_topic.items()):
            if published.get(topic) != channel.type_name:
                del self.by_topic[topic], self.by_id[channel.id]
                changes.removed.append(channel.id)
        for topic, type_name in published.items():
            if topic in self.by_topic:
                continue
            text = self._definition(type_name)
            if text is not None:
                channel = Channel(next(self._ids), topic, type_name, text)
                self.by_topic[topic] = self.by_id[channel.id] = channel
                changes.added.append(channel.advert())
        return changes

    def reconcile_services(self, provided: Mapping[str, str]) -> Changes:
        """`provided`: service -> type of every service someone answers."""
        changes = Changes()
        for name, service in list(self.services_by_name.items()):
            if provided.get(name) != service.type_name:
                del self.services_by_name[name], self.services_by_id[service.id]
                changes.removed.append(service.id)
        for name, type_name in provided.items():
            if name not in self.services_by_name:
                made = self._service(name, type_name)
                if made is not None:
                    self.services_by_name[name] = self.services_by_id[made.id] = made
                    changes.added.append(made.advert())
        return changes

    def channel_adverts(self) -> list[dict[str, Any]]:
        return [channel.advert() for channel in self.by_id.values()]

    def service_adverts(self) -> list[dict[str, Any]]:
        return [service.advert() for service in self.services_by_id.values()]

    def _service(self, name: str, type_name: str) -> Service | None:
        try:
            spec = self._registry.service(type_name)
        except SchemaError:
            return None
        request, response = spec.request.name, spec.response.name
        request_text, response_text = self._definition(request), self._definition(response)
        if request_text is None or response_text is None:
            return None
        return Service(
            next(self._ids), name, spec.name, request, response, request_text, response_text
        )

    def _definition(self, type_name: str) -> str | None:
        if type_name not in self._texts:
            try:
                self._texts[type_name] = self._registry.full_text(type_name)
            except (SchemaError, KeyError):
                self._texts[type_name] = None
        return self._texts[type_name]


def published_topics(entries: Iterable[Any]) -> dict[str, str]:
    """topic -> type of graph entries (`bridge.graph.TopicEntry`) that have a publisher."""
    return {e.name: e.type_name for e in entries if e.publishers and e.type_name is not None}
