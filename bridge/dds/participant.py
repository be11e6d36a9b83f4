"""The Cyclone DDS shell: one domain participant, raw-CDR writers and readers, discovery.

Cyclone's Python binding serializes IDL objects; the mirror already has CDR from rosbags, so
it bypasses the object layer at both ends. Writing calls the C library's `dds_write` through
ctypes with the binding's sample container (a pointer to CDR bytes and their length): ctypes
releases the GIL, so a reliable writer that must wait for acknowledgements never stalls the
event loop. Taking uses the binding's `ddspy_take`, which hands back each sample's CDR bytes
with its sample info. Samples are taken on one pump thread that waits on a Cyclone wait set,
never in a listener: a listener runs on Cyclone's receive thread, which would then wait for
the GIL while the event loop works and stop acknowledging fragments.
"""

from __future__ import annotations

import ctypes
import itertools
import logging
import threading
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cyclonedds._clayer import ddspy_take
from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import (
    Entity,
    GuardCondition,
    InstanceState,
    Qos,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.internal import load_cyclonedds
from cyclonedds.pub import DataWriter, Publisher
from cyclonedds.qos import Policy
from cyclonedds.sub import DataReader, Subscriber
from cyclonedds.topic import Topic

from bridge.dds.cyclone_xml import CycloneSettings, cyclone_xml
from bridge.dds.discovery import DiscoveryDelta, Endpoint
from bridge.dds.idl_types import IdlTypes
from bridge.dds.outbox import Outbox
from bridge.dds.qos import QosProfile
from schemas.registry import TypeRegistry

logger = logging.getLogger("bridge.dds")

_LIB = load_cyclonedds()
_dds_write = _LIB.dds_write
_dds_write.argtypes = [ctypes.c_int32, ctypes.c_void_p]
_dds_write.restype = ctypes.c_int32
_dds_triggered = _LIB.dds_triggered
_dds_triggered.argtypes = [ctypes.c_int32]
_dds_triggered.restype = ctypes.c_int32
DDS_INFINITY = 0x7FFFFFFFFFFFFFFF
# A reliable write waits at most this long for room in the writer's history cache.
MAX_BLOCKING_NS = 1_000_000_000
PUMP_WAIT_NS = 500_000_000
TAKE_LIMIT = 256  # samples per reader per wake-up
# Discovery samples per read: the binding allocates (and the GIL holds) room for as many as
# asked, so a large N costs per call what a million samples would; reads loop in chunks.
DISCOVERY_CHUNK = 64
_ANY = SampleState.Any | ViewState.Any | InstanceState.Any
_FRESH = SampleState.NotRead | ViewState.Any | InstanceState.Alive
_NOT_ALIVE = (
    SampleState.Any
    | ViewState.Any
    | InstanceState.NotAliveDisposed
    | InstanceState.NotAliveNoWriters
)


class _SampleContainer(ctypes.Structure):
    """The Python binding's sample: serialized bytes (encapsulation header first)."""

    _fields_ = [("usample", ctypes.c_void_p), ("usample_size", ctypes.c_size_t)]


@dataclass(frozen=True, slots=True)
class RawSample:
    """One taken sample: its CDR (with header) and which remote writer sent it."""

    data: bytes
    publication_handle: int
    source_timestamp_ns: int


def cyclone_qos(profile: QosProfile, user_data: str = "", writer: bool = False) -> Qos:
    """ROS 2's QoS for an endpoint, the way rmw_cyclonedds_cpp sets it."""
    history = (
        Policy.History.KeepAll if profile.depth == 0 else Policy.History.KeepLast(profile.depth)
    )
    policies: list[Any] = [
        Policy.Reliability.Reliable(MAX_BLOCKING_NS)
        if profile.reliable
        else Policy.Reliability.BestEffort,
        Policy.Durability.TransientLocal if profile.transient_local else Policy.Durability.Volatile,
        history,
    ]
    if writer:
        policies.append(Policy.WriterDataLifecycle(autodispose=False))
    else:
        policies.append(Policy.IgnoreLocal.Participant)
    if user_data:
        policies.append(Policy.Userdata(data=user_data.encode()))
    return Qos(*policies)


def profile_of(qos: Qos | None) -> QosProfile:
    """The ROS view of a discovered endpoint's QoS (DDS defaults where a policy is absent)."""
    if qos is None:
        return QosProfile()
    reliability, durability, history = (
        qos[Policy.Reliability],
        qos[Policy.Durability],
        qos[Policy.History],
    )
    depth = 0 if history == Policy.History.KeepAll else getattr(history, "depth", 1)
    return QosProfile(
        reliable=isinstance(reliability, Policy.Reliability.Reliable),
        transient_local=durability not in (None, Policy.Durability.Volatile),
        depth=depth,
    )


def user_data_of(qos: Qos | None) -> str:
    policy = qos[Policy.Userdata] if qos is not None else None
    data = getattr(policy, "data", b"") or b""
    return data.decode("utf-8", "replace")


class RawWriter:
    """A DataWriter fed with CDR bytes."""

    def __init__(self, entity: DataWriter[IdlStruct]) -> None:
        self.entity = entity
        self.guid = entity.guid.bytes
        self.instance_handle = entity.get_instance_handle() & 0xFFFF_FFFF_FFFF_FFFF  # uint64

    def write(self, cdr: bytes) -> int:
        """Write one sample; returns Cyclone's return code (0 = written). Releases the GIL."""
        buffer = ctypes.c_char_p(cdr)
        container = _SampleContainer(ctypes.cast(buffer, ctypes.c_void_p), len(cdr))
        return int(_dds_write(self.entity._ref, ctypes.byref(container)))


class RawReader:
    """A DataReader whose samples are taken as CDR bytes."""

    def __init__(self, entity: DataReader[IdlStruct]) -> None:
        self.entity = entity
        self.guid = entity.guid.bytes
        self.condition = ReadCondition(
            entity, SampleState.NotRead | ViewState.Any | InstanceState.Any
        )

    def take(self) -> list[RawSample]:
        taken = ddspy_take(self.entity._ref, _ANY, TAKE_LIMIT)
        if isinstance(taken, int):
            raise RuntimeError(f"dds_take failed with {taken}")
        return [
            RawSample(data, info.publication_handle, info.source_timestamp)
            for data, info in taken
            if info.valid_data
        ]

    def writer_guid(self, publication_handle: int) -> bytes | None:
        """The GUID of the matched remote writer `publication_handle`, if still matched."""
        try:
            endpoint = self.entity.get_matched_publication_data(publication_handle)
        except Exception:  # the writer may be gone already
            return None
        return endpoint.key.bytes if endpoint is not None else None


class _Domains:
    """Cyclone domains are per process: bridges of one process that join the same domain
    id share one `Domain` (same configuration) and release it with the last participant."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._held: dict[int, tuple[Domain, str, int]] = {}

    def acquire(self, domain_id: int, xml: str) -> Domain:
        with self._lock:
            held = self._held.get(domain_id)
            if held is None:
                held = (Domain(domain_id, xml), xml, 0)
            elif held[1] != xml:
                raise ValueError(
                    f"DDS domain {domain_id} is already configured differently in this process"
                )
            self._held[domain_id] = (held[0], held[1], held[2] + 1)
            return held[0]

    def release(self, domain_id: int) -> None:
        with self._lock:
            domain, xml, count = self._held[domain_id]
            if count > 1:
                self._held[domain_id] = (domain, xml, count - 1)
                return
            del self._held[domain_id]
            domain.__del__()  # now, so the id can be joined again at once


DOMAINS = _Domains()


class DdsParticipant:
    """One participant in domain `domain_id`, configured by `settings` (never Cyclone's
    defaults), with ROS 2's participant user data so ROS 2 tools list it."""

    def __init__(self, domain_id: int, settings: CycloneSettings, tuned: bool = True) -> None:
        self.domain_id = domain_id
        self._domain = DOMAINS.acquire(domain_id, cyclone_xml(settings, tuned))
        try:
            self.participant = DomainParticipant(
                domain_id, qos=Qos(Policy.Userdata(data=b"enclave=/;"))
            )
        except Exception:
            DOMAINS.release(domain_id)
            raise
        self.guid = self.participant.guid.bytes
        self.publisher = Publisher(self.participant)
        self.subscriber = Subscriber(self.participant)
        self.types = IdlTypes()
        self.pairings = itertools.count(1)  # numbers rmw-style client/service pairing ids
        self._topics: dict[str, Topic[IdlStruct]] = {}
        self._lock = threading.Lock()
        self._discovery = [
            BuiltinDataReader(self.participant, topic)
            for topic in (
                BuiltinTopicDcpsParticipant,
                BuiltinTopicDcpsPublication,
                BuiltinTopicDcpsSubscription,
            )
        ]
        self.discovery_conditions = [
            ReadCondition(r, SampleState.NotRead | ViewState.Any | InstanceState.Any)
            for r in self._discovery
        ]
        self._fresh = [ReadCondition(r, _FRESH) for r in self._discovery]
        self._gone = [ReadCondition(r, _NOT_ALIVE) for r in self._discovery]

    def short_id(self) -> str:
        """Eight hex digits naming this participant (its node name's suffix)."""
        return f"{zlib.crc32(self.guid[:12]):08x}"

    def topic(self, dds_name: str, data_type: type[IdlStruct]) -> Topic[IdlStruct]:
        with self._lock:
            topic = self._topics.get(dds_name)
            if topic is None:
                topic = self._topics[dds_name] = Topic(self.participant, dds_name, data_type)
            return topic

    def writer(
        self, dds_name: str, data_type: type, profile: QosProfile, user_data: str = ""
    ) -> RawWriter:
        topic = self.topic(dds_name, data_type)
        return RawWriter(
            DataWriter(self.publisher, topic, cyclone_qos(profile, user_data, writer=True))
        )

    def reader(
        self, dds_name: str, data_type: type, profile: QosProfile, user_data: str = ""
    ) -> RawReader:
        topic = self.topic(dds_name, data_type)
        return RawReader(DataReader(self.subscriber, topic, cyclone_qos(profile, user_data)))

    @staticmethod
    def delete(entity: Entity) -> None:
        """Delete a writer, reader or condition now (not when Python collects it)."""
        entity.__del__()

    def discovery_changes(self) -> DiscoveryDelta:
        """What discovery reported since the last call (ours left out): the departed are
        taken (their instances end), the new and changed are read once (kept as read)."""
        gone = [
            {s.key.bytes for s in _drain(reader.take, condition)}
            for reader, condition in zip(self._discovery, self._gone, strict=True)
        ]
        fresh = [
            _drain(reader.read, condition)
            for reader, condition in zip(self._discovery, self._fresh, strict=True)
        ]
        endpoints = [
            Endpoint(
                sample.key.bytes,
                sample.participant_key.bytes,
                sample.topic_name,
                sample.type_name,
                is_writer,
                profile_of(sample.qos),
                user_data_of(sample.qos),
            )
            for samples, is_writer in ((fresh[1], True), (fresh[2], False))
            for sample in samples
            if sample.sample_info.valid_data and sample.participant_key.bytes != self.guid
        ]
        return DiscoveryDelta(
            frozenset(p.key.bytes for p in fresh[0] if p.sample_info.valid_data) - {self.guid},
            tuple(endpoints),
            frozenset(gone[0]) - {self.guid},
            frozenset(gone[1] | gone[2]),
        )

    def close(self) -> None:
        try:
            self.delete(self.participant)
        finally:
            DOMAINS.release(self.domain_id)


def _drain(read: Callable[..., list[Any]], condition: ReadCondition) -> list[Any]:
    """Everything `condition` selects, `DISCOVERY_CHUNK` samples per call."""
    samples: list[Any] = []
    while True:
        chunk = read(N=DISCOVERY_CHUNK, condition=condition)
        samples.extend(chunk)
        if len(chunk) < DISCOVERY_CHUNK:
            return samples


# Runs on the pump thread under its lock (take samples, quickly) and returns the rest of the
# work (decode, hand over), which runs outside the lock, or None.
Handler = Callable[[], Callable[[], None] | None]


class Pump:
    """One thread that waits on a Cyclone wait set and runs the handler of whatever woke it.

    `watch`/`unwatch` may be called from any thread; once `unwatch` returns, the condition's
    handler is not taking samples any more (its entity may then be deleted).
    """

    def __init__(self, participant: DdsParticipant) -> None:
        self._waitset = WaitSet(participant.participant)
        self._wake = GuardCondition(participant.participant)
        self._waitset.attach(self._wake)
        self._handlers: dict[int, tuple[Entity, Handler]] = {}
        self._lock = threading.Lock()
        self._running = True
        self._thread = threading.Thread(target=self._run, name="bridge-dds-pump", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def watch(self, condition: Entity, handler: Handler) -> None:
        with self._lock:
            self._handlers[id(condition)] = (condition, handler)
            self._waitset.attach(condition)
        self._wake.set(True)

    def unwatch(self, condition: Entity) -> None:
        with self._lock:
            if self._handlers.pop(id(condition), None) is not None:
                self._waitset.detach(condition)

    def stop(self) -> None:
        self._running = False
        self._wake.set(True)
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        while self._running:
            self._waitset.wait(PUMP_WAIT_NS)
            self._wake.set(False)
            with self._lock:
                handlers = list(self._handlers.values())
            for condition, handler in handlers:
                if not self._running:
                    return
                if _dds_triggered(condition._ref) <= 0:
                    continue
                try:
                    with self._lock:
                        rest = handler() if self._still_watched(handler) else None
                    if rest is not None:
                        rest()
                except Exception:  # one bad sample must not stop the pump
                    logger.exception("DDS: a sample handler failed")

    def _still_watched(self, handler: Handler) -> bool:
        return any(h is handler for _, h in self._handlers.values())


@dataclass(frozen=True)
class DdsPlumbing:
    """What each part of the mirror (topics, services, discovery announcements) works with:
    the one participant, the pump thread taking its samples, the outbox its writes leave
    through, and the registry that turns messages into CDR and back."""

    participant: DdsParticipant
    pump: Pump
    outbox: Outbox
    registry: TypeRegistry
    distro: str = "jazzy"  # --ros-distro: Humble's endpoints carry no type hash

    def type_hash(self, type_name: str) -> str:
        """The endpoint user data naming `type_name`'s hash (REP 2011, Iron and later)."""
        if self.distro == "humble":
            return ""
        try:
            return f"typehash={self.registry.typestore.hash_rihs01(type_name)};"
        except Exception:  # older rosbags or a type it cannot hash: the hash is informational
            return ""
