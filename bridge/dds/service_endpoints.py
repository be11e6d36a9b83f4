"""One ROS 2 service on DDS, from either side: the server's or a client's endpoints.

A server reads `rq/<s>Request` and writes `rr/<s>Reply`; a client writes requests and reads
replies. Both carry rmw_cyclonedds's request header (`bridge.dds.request_header`), and both
put rmw_cyclonedds's pairing key in their endpoints' user data (`serviceid=…;` on a server's
two endpoints, `clientid=…;` on a client's), which a ROS 2 service uses to wait until a
client's reply reader is matched before it answers.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable

from bridge.dds import request_header
from bridge.dds.naming import ACTION_INFIX, reply_topic, request_topic
from bridge.dds.participant import DdsPlumbing, RawReader, RawWriter
from bridge.dds.qos import SERVICES
from bridge.dds.request_header import RequestId
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.values import Message

logger = logging.getLogger("bridge.dds")

Received = Callable[[str, RequestId, Message], object]  # (service, id, message)
# A Fast DDS server's reply later than this is taken as lost (ServiceClient): above the
# bridge's default call timeout (5 s), so a slow answer still reaches a waiting caller.
STALE_S = 10.0


def pairing_id(participant_guid: bytes, number: int) -> str:
    """rmw_cyclonedds's client/service id: the participant's GUID prefix and a counter,
    as dot-separated hex bytes."""
    return ".".join(f"{b:x}" for b in participant_guid[:12] + number.to_bytes(4, "big"))


class _ServiceEndpoints:
    """The writer and reader of one side of a service, and the types they carry."""

    def __init__(
        self,
        dds: DdsPlumbing,
        service: str,
        type_name: str,
        is_server: bool,
        received: Received,
        request_header: bool = True,
    ) -> None:
        participant, registry = dds.participant, dds.registry
        self.request_header = request_header
        spec = registry.service(type_name)
        self.service = service
        self.type_name = spec.name
        self._dds = dds
        self._received = received  # called on the pump thread
        outgoing, incoming = (
            (spec.response, spec.request) if is_server else (spec.request, spec.response)
        )
        self._outgoing, self._incoming = outgoing.name, incoming.name
        key = (
            ("serviceid=" if is_server else "clientid=")
            + pairing_id(participant.guid, next(participant.pairings))
            + ";"
        )
        types = participant.types
        part_type = types.service_part if request_header else types.message
        write_topic, read_topic = (
            (reply_topic(service), request_topic(service))
            if is_server
            else (request_topic(service), reply_topic(service))
        )
        self.writer: RawWriter = participant.writer(
            write_topic,
            part_type(outgoing),
            SERVICES,
            key + dds.type_hash(outgoing.name),
        )
        self.reader: RawReader = participant.reader(
            read_topic,
            part_type(incoming),
            SERVICES,
            key + dds.type_hash(incoming.name),
        )
        dds.pump.watch(self.reader.condition, self._take)

    def send(self, request: RequestId, msg: Message) -> None:
        """Queue a request or reply (serialized and written on the writer thread)."""

        def write() -> None:
            cdr = to_cdr(self._dds.registry, self._outgoing, msg)
            if self.request_header:
                cdr = request_header.wrap(cdr, request)
            result = self.writer.write(cdr)
            if result < 0:
                logger.warning("DDS: write for service %s failed (%d)", self.service, result)

        self._dds.outbox.put(("service", self.service, id(self)), write)

    def accepts(self, request: RequestId) -> bool:
        return True

    def _take(self) -> Callable[[], None] | None:
        samples = self.reader.take()
        if not samples:
            return None

        def decode() -> None:
            for sample in samples:
                try:
                    request, cdr = self._unwrap(sample.data)
                    if request is not None and self.accepts(request):
                        self._received(
                            self.service, request, from_cdr(self._dds.registry, self._incoming, cdr)
                        )
                except (SchemaError, ValueError) as exc:
                    logger.warning("DDS: dropped a sample of service %s: %s", self.service, exc)

        return decode

    def _unwrap(self, sample: bytes) -> tuple[RequestId | None, bytes]:
        return request_header.unwrap(sample)

    def guids(self) -> tuple[bytes, bytes]:
        """(reader GUID, writer GUID)."""
        return self.reader.guid, self.writer.guid

    def close(self) -> None:
        self._dds.pump.unwatch(self.reader.condition)
        self._dds.participant.delete(self.reader.entity)
        self._dds.participant.delete(self.writer.entity)


class ServiceServer(_ServiceEndpoints):
    """A local provider's service offered on DDS: requests in, replies out."""

    def __init__(
        self,
        dds: DdsPlumbing,
        service: str,
        type_name: str,
        on_request: Received,
        request_header: bool = True,
    ) -> None:
        super().__init__(dds, service, type_name, True, on_request, request_header)


class ServiceClient(_ServiceEndpoints):
    """A remote server's service used by local callers: requests out, own replies in.

    Towards a Fast DDS server (`request_header=False`) the request id travels in RTPS inline
    QoS, which Cyclone neither writes nor reads: requests then go one at a time and a reply
    answers the request in flight. A reply the server sends to another client of the same
    service at that moment would be taken for ours (documented in docs/ros2.md). A request
    unanswered for `STALE_S` (a server that lost it) gives its turn to the next one, except
    an action's `get_result`, which answers only when its goal ends.
    """

    def __init__(
        self,
        dds: DdsPlumbing,
        service: str,
        type_name: str,
        on_reply: Received,
        request_header: bool = True,
    ) -> None:
        super().__init__(dds, service, type_name, False, on_reply, request_header)
        self._sequence = itertools.count(1)
        self._lock = threading.Lock()  # requests come from the loop, replies on the pump
        self._in_flight: RequestId | None = None
        self._in_flight_since = 0.0
        self._queued: deque[tuple[RequestId, Message]] = deque()
        self._stale_s = None if service.endswith(ACTION_INFIX + "get_result") else STALE_S

    def request(self, msg: Message) -> RequestId:
        """Send a request; its reply comes back with the returned id."""
        request = RequestId(self.writer.instance_handle, next(self._sequence))
        if self.request_header:
            self.send(request, msg)
            return request
        now_s = time.monotonic()
        with self._lock:
            if self._in_flight is not None and not self._stale(now_s):
                self._queued.append((request, msg))
                return request
            if self._in_flight is not None:
                logger.warning(
                    "DDS: %s gave no reply in %g s; sending the next request", self.service, STALE_S
                )
            self._in_flight, self._in_flight_since = request, now_s
        self.send(request, msg)
        return request

    def _stale(self, now_s: float) -> bool:
        return self._stale_s is not None and now_s - self._in_flight_since > self._stale_s

    def _unwrap(self, sample: bytes) -> tuple[RequestId | None, bytes]:
        if self.request_header:
            return request_header.unwrap(sample)
        with self._lock:
            answered = self._in_flight
        if answered is not None:
            self._next()
        return answered, sample

    def _next(self) -> None:
        with self._lock:
            following = self._queued.popleft() if self._queued else None
            self._in_flight = following[0] if following else None
            self._in_flight_since = time.monotonic()
        if following is not None:
            self.send(*following)

    def accepts(self, request: RequestId) -> bool:
        """Replies go to every client of a service; keep those answering our requests."""
        return request.guid == self.writer.instance_handle
