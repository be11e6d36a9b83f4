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
from collections.abc import Callable

from bridge.dds import request_header
from bridge.dds.naming import reply_topic, request_topic
from bridge.dds.participant import DdsPlumbing, RawReader, RawWriter
from bridge.dds.qos import SERVICES
from bridge.dds.request_header import RequestId
from bridge.dds.topic_mirror import type_hash_user_data
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.errors import SchemaError
from schemas.values import Message

logger = logging.getLogger("bridge.dds")

Received = Callable[[str, RequestId, Message], object]  # (service, id, message)


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
    ) -> None:
        participant, registry = dds.participant, dds.registry
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
        write_topic, read_topic = (
            (reply_topic(service), request_topic(service))
            if is_server
            else (request_topic(service), reply_topic(service))
        )
        self.writer: RawWriter = participant.writer(
            write_topic,
            types.service_part(outgoing),
            SERVICES,
            key + type_hash_user_data(registry, outgoing.name),
        )
        self.reader: RawReader = participant.reader(
            read_topic,
            types.service_part(incoming),
            SERVICES,
            key + type_hash_user_data(registry, incoming.name),
        )
        dds.pump.watch(self.reader.condition, self._take)

    def send(self, request: RequestId, msg: Message) -> None:
        """Queue a request or reply (serialized and written on the writer thread)."""

        def write() -> None:
            cdr = request_header.wrap(to_cdr(self._dds.registry, self._outgoing, msg), request)
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
                    request, cdr = request_header.unwrap(sample.data)
                    if self.accepts(request):
                        self._received(
                            self.service, request, from_cdr(self._dds.registry, self._incoming, cdr)
                        )
                except (SchemaError, ValueError) as exc:
                    logger.warning("DDS: dropped a sample of service %s: %s", self.service, exc)

        return decode

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
    ) -> None:
        super().__init__(dds, service, type_name, True, on_request)


class ServiceClient(_ServiceEndpoints):
    """A remote server's service used by local callers: requests out, own replies in."""

    def __init__(
        self,
        dds: DdsPlumbing,
        service: str,
        type_name: str,
        on_reply: Received,
    ) -> None:
        super().__init__(dds, service, type_name, False, on_reply)
        self._sequence = itertools.count(1)

    def request(self, msg: Message) -> RequestId:
        """Send a request; its reply comes back with the returned id."""
        request = RequestId(self.writer.instance_handle, next(self._sequence))
        self.send(request, msg)
        return request

    def accepts(self, request: RequestId) -> bool:
        """Replies go to every client of a service; keep those answering our requests."""
        return request.guid == self.writer.instance_handle
