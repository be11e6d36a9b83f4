"""Topics between the bridge and Zenoh: a publisher per topic clients publish, a subscriber per
topic clients read, on rmw_zenoh's keys with its attachment and tokens.

A transient-local publisher keeps its last `depth` samples in a publication cache (zenoh-ext's
advanced publisher, as rmw_zenoh does); a transient-local subscriber asks late publishers'
caches for their history. Samples are checked and decoded on Zenoh's thread; a bad one is
dropped with a rate-limited line (`ProblemLog`) and the rest go on.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import zenoh
import zenoh.ext

from bridge.dds.qos import QosProfile
from bridge.outgoing import TopicMessage
from bridge.zenoh.attachment import (
    Attachment,
    AttachmentProblem,
    decode_attachment,
    encode_attachment,
)
from bridge.zenoh.keys import KeyProblem, data_key, parse_data_key, type_hash
from bridge.zenoh.liveliness import Endpoint, EntityKind
from bridge.zenoh.node import Declared, ZenohNode
from bridge.zenoh.problems import ProblemLog
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.registry import TypeRegistry
from schemas.values import Message


@dataclass(frozen=True)
class Wanted:
    """A topic endpoint the mirror wants: its type and QoS."""

    type_name: str
    qos: QosProfile


@dataclass(frozen=True)
class Arrival:
    """A checked, decoded sample from Zenoh."""

    topic: str
    type_name: str
    msg: Message
    cdr: bytes
    source_gid: bytes


@dataclass
class _Publisher:
    wanted: Wanted
    raw: Any  # zenoh.Publisher or zenoh.ext.AdvancedPublisher
    declared: Declared
    sequence: itertools.count[int]


@dataclass
class _Subscriber:
    wanted: Wanted
    raw: Any  # zenoh.Subscriber or zenoh.ext.AdvancedSubscriber
    declared: Declared


class ZenohTopics:
    """Creates and replaces the node's publishers and subscribers; puts and takes samples."""

    def __init__(
        self,
        node: ZenohNode,
        registry: TypeRegistry,
        deliver: Callable[[Arrival], object],
        problems: ProblemLog,
    ) -> None:
        self._node = node
        self._registry = registry
        self._deliver = deliver  # called on Zenoh's thread; must hop to the loop itself
        self._problems = problems
        self.publishers: dict[str, _Publisher] = {}
        self.subscribers: dict[str, _Subscriber] = {}

    def sync(self, publishers: dict[str, Wanted], subscribers: dict[str, Wanted]) -> None:
        for topic in [t for t, p in self.publishers.items() if publishers.get(t) != p.wanted]:
            _close(self.publishers.pop(topic))
        for topic in [t for t, s in self.subscribers.items() if subscribers.get(t) != s.wanted]:
            _close(self.subscribers.pop(topic))
        for topic, wanted in publishers.items():
            if topic not in self.publishers:
                self.publishers[topic] = self._publisher(topic, wanted)
        for topic, wanted in subscribers.items():
            if topic not in self.subscribers:
                self.subscribers[topic] = self._subscriber(topic, wanted)

    def _endpoint(self, topic: str, wanted: Wanted) -> tuple[str, Endpoint]:
        hash_ = type_hash(self._registry, wanted.type_name, self._node.distro)
        key = data_key(self._node.domain, topic, wanted.type_name, hash_)
        return key, Endpoint(topic, wanted.type_name, hash_, wanted.qos)

    def _publisher(self, topic: str, wanted: Wanted) -> _Publisher:
        key, endpoint = self._endpoint(topic, wanted)
        session = self._node.session
        congestion = (
            zenoh.CongestionControl.BLOCK if wanted.qos.depth == 0 else zenoh.CongestionControl.DROP
        )
        raw: Any
        if wanted.qos.transient_local:
            raw = zenoh.ext.declare_advanced_publisher(
                session,
                key,
                congestion_control=congestion,
                cache=zenoh.ext.CacheConfig(max_samples=max(wanted.qos.depth, 1)),
                publisher_detection=True,
            )
        else:
            raw = session.declare_publisher(key, congestion_control=congestion)
        declared = self._node.declare(EntityKind.PUBLISHER, endpoint)
        return _Publisher(wanted, raw, declared, itertools.count(1))

    def _subscriber(self, topic: str, wanted: Wanted) -> _Subscriber:
        key, endpoint = self._endpoint(topic, wanted)
        # Any type and hash: a sample whose key names another type is said, not ignored.
        listen = key.rsplit("/", 2)[0] + "/*/*"

        def on_sample(sample: zenoh.Sample) -> None:
            self._take(topic, wanted, sample)

        raw: Any
        if wanted.qos.transient_local:
            raw = zenoh.ext.declare_advanced_subscriber(
                self._node.session,
                listen,
                on_sample,
                allowed_origin=zenoh.Locality.REMOTE,
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True),
            )
        else:
            raw = self._node.session.declare_subscriber(
                listen, on_sample, allowed_origin=zenoh.Locality.REMOTE
            )
        declared = self._node.declare(EntityKind.SUBSCRIPTION, endpoint)
        return _Subscriber(wanted, raw, declared)

    # -- samples -----------------------------------------------------------------------------

    def send(self, message: TopicMessage) -> bool:
        """Put `message` on its topic's publisher; False if the topic has none (yet)."""
        publisher = self.publishers.get(message.topic)
        if publisher is None or publisher.wanted.type_name != message.type_name:
            return False
        if message.cdr is None:
            message.cdr = to_cdr(self._registry, message.type_name, message.msg)
        attachment = Attachment(next(publisher.sequence), message.stamp_ns, publisher.declared.gid)
        publisher.raw.put(message.cdr, attachment=encode_attachment(attachment))
        return True

    def _take(self, topic: str, wanted: Wanted, sample: zenoh.Sample) -> None:
        """Check and decode one sample (on Zenoh's thread); deliver it or say why not."""
        key = str(sample.key_expr)
        try:
            parsed = parse_data_key(key)
            if parsed.type_name != wanted.type_name:
                raise KeyProblem(f"key {key} names type {parsed.type_name}, not {wanted.type_name}")
            attachment = sample.attachment
            gid = decode_attachment(None if attachment is None else attachment.to_bytes())
        except KeyProblem as exc:
            self._problems.dropped(topic, "sample with an unknown type in its key", str(exc))
            return
        except AttachmentProblem as exc:
            self._problems.dropped(topic, "sample with a bad attachment", str(exc))
            return
        cdr = sample.payload.to_bytes()
        try:
            msg = from_cdr(self._registry, wanted.type_name, cdr)
        except Exception as exc:  # rosbags raises whatever its reader meets
            detail = f"{len(cdr)} bytes do not decode as {wanted.type_name}: {exc!r}"
            self._problems.dropped(topic, "undecodable sample", detail)
            return
        self._deliver(Arrival(topic, wanted.type_name, msg, cdr, gid.source_gid))

    def close(self) -> None:
        self.sync({}, {})


def _close(endpoint: _Publisher | _Subscriber) -> None:
    endpoint.declared.close()
    endpoint.raw.undeclare()
