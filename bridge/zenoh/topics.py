"""Topics between the bridge and Zenoh: a publisher per topic clients publish, a subscriber per
topic clients read, on rmw_zenoh's keys with its attachment and tokens.

Small messages are put from the event loop with *drop* congestion control at Zenoh's `DATA`
priority. A topic whose messages are large (over `BULK_BYTES`: a scan, an image) moves to
`DATA_LOW` with *block*, its messages put by `BulkWriter`'s thread, newest first: Zenoh
fragments them and serves its priority queues in order, so on a thin link an IMU sample waits
behind one batch of a scan instead of the whole scan, and scans arrive whole.
A transient-local publisher keeps its last `depth` samples in a publication cache (zenoh-ext's
advanced publisher, as rmw_zenoh does); a transient-local subscriber asks late publishers'
caches for their history. Samples are checked and decoded on Zenoh's thread; a bad one is
dropped with a rate-limited line (`ProblemLog`) and the rest go on.
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from typing import Any

import zenoh
import zenoh.ext

from bridge.graph_mirror import Arrival, Wanted
from bridge.outgoing import TopicMessage
from bridge.zenoh.attachment import (
    Attachment,
    AttachmentProblem,
    decode_attachment,
    encode_attachment,
)
from bridge.zenoh.bulk import BulkWriter
from bridge.zenoh.keys import KeyProblem, data_key, parse_data_key, type_hash
from bridge.zenoh.liveliness import Endpoint, EntityKind
from bridge.zenoh.node import Declared, ZenohNode
from bridge.zenoh.problems import ProblemLog
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.registry import TypeRegistry

BULK_BYTES = 64 * 1024  # Zenoh's default batch: a larger message is sent in fragments


@dataclass
class _Publisher:
    key: str
    wanted: Wanted
    raw: Any  # zenoh.Publisher or zenoh.ext.AdvancedPublisher
    declared: Declared
    sequence: itertools.count[int]
    bulk: bool = False  # moved to DATA_LOW after its first large message


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
        self.bulk = BulkWriter()

    def sync(self, publishers: dict[str, Wanted], subscribers: dict[str, Wanted]) -> None:
        for topic in [t for t, p in self.publishers.items() if publishers.get(t) != p.wanted]:
            _close(self.publishers.pop(topic))
        for topic in [t for t, s in self.subscribers.items() if subscribers.get(t) != s.wanted]:
            _close(self.subscribers.pop(topic))
        for topic, wanted in publishers.items():
            if topic not in self.publishers:
                with self._refusal(topic):
                    self.publishers[topic] = self._publisher(topic, wanted)
        for topic, wanted in subscribers.items():
            if topic not in self.subscribers:
                with self._refusal(topic):
                    self.subscribers[topic] = self._subscriber(topic, wanted)

    @contextlib.contextmanager
    def _refusal(self, topic: str) -> Iterator[None]:
        """A topic Zenoh refuses (or whose type has no DDS name) is said, not fatal to the
        others; it is tried again at the next reconcile."""
        try:
            yield
        except (KeyProblem, ValueError, zenoh.ZError) as exc:
            self._problems.dropped(topic, "topic not mirrored", str(exc))

    def _endpoint(self, topic: str, wanted: Wanted) -> tuple[str, Endpoint]:
        hash_ = type_hash(self._registry, wanted.type_name, self._node.distro)
        key = data_key(self._node.domain, topic, wanted.type_name, hash_)
        return key, Endpoint(topic, wanted.type_name, hash_, wanted.profile)

    def _publisher(self, topic: str, wanted: Wanted) -> _Publisher:
        key, endpoint = self._endpoint(topic, wanted)
        raw = self._declare_raw(key, wanted, bulk=False)
        declared = self._node.declare(EntityKind.PUBLISHER, endpoint)
        return _Publisher(key, wanted, raw, declared, itertools.count(1))

    def _declare_raw(self, key: str, wanted: Wanted, bulk: bool) -> Any:
        session = self._node.session
        priority = zenoh.Priority.DATA_LOW if bulk else zenoh.Priority.DATA
        blocking = bulk or wanted.profile.depth == 0  # keep-all, or put from the bulk thread
        congestion = zenoh.CongestionControl.BLOCK if blocking else zenoh.CongestionControl.DROP
        if wanted.profile.transient_local:
            return zenoh.ext.declare_advanced_publisher(
                session,
                key,
                congestion_control=congestion,
                priority=priority,
                cache=zenoh.ext.CacheConfig(max_samples=max(wanted.profile.depth, 1)),
                publisher_detection=True,
            )
        return session.declare_publisher(key, congestion_control=congestion, priority=priority)

    def _subscriber(self, topic: str, wanted: Wanted) -> _Subscriber:
        key, endpoint = self._endpoint(topic, wanted)
        # Any type and hash: a sample whose key names another type is said, not ignored.
        listen = key.rsplit("/", 2)[0] + "/*/*"

        def on_sample(sample: zenoh.Sample) -> None:
            self._take(topic, wanted, sample)

        raw: Any
        if wanted.profile.transient_local:
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
        sequence = next(publisher.sequence)
        if publisher.bulk or message.size_hint > BULK_BYTES:
            if not publisher.bulk:
                self._to_bulk(publisher)
            job = partial(self._put, publisher, message, sequence)
            self.bulk.put(message.topic, job, message.size_hint)
        else:
            self._put(publisher, message, sequence)
        return True

    def _put(self, publisher: _Publisher, message: TopicMessage, sequence: int) -> None:
        if message.cdr is None:
            message.cdr = to_cdr(self._registry, message.type_name, message.msg)
        attachment = Attachment(sequence, message.stamp_ns, publisher.declared.gid)
        publisher.raw.put(message.cdr, attachment=encode_attachment(attachment))

    def _to_bulk(self, publisher: _Publisher) -> None:
        """Re-declare the publisher at DATA_LOW with *block* (it is put from the bulk thread
        from now on)."""
        publisher.bulk = True
        old = publisher.raw
        publisher.raw = self._declare_raw(publisher.key, publisher.wanted, bulk=True)
        old.undeclare()

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
        self.bulk.close()
        self.sync({}, {})


def _close(endpoint: _Publisher | _Subscriber) -> None:
    endpoint.declared.close()
    endpoint.raw.undeclare()
