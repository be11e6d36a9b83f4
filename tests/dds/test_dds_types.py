"""Every message type the bridge knows crosses Cyclone DDS as rosbags' CDR, byte for byte.

Cyclone checks each sample against the type it registered for the topic (built here from the
registry's spec), so a mapping mistake (alignment, bounds, a missing placeholder member)
makes the write or the read fail. The messages carry data in every sequence the defaults
leave empty where it is cheap to add some.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from bridge.dds import request_header
from bridge.dds.cyclone_xml import CycloneSettings
from bridge.dds.naming import topic_to_dds
from bridge.dds.participant import DdsParticipant, RawReader, RawWriter
from bridge.dds.qos import DEFAULT, SERVICES
from bridge.dds.request_header import RequestId
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.message import normalize

MATCH_TIMEOUT_S = 20.0


@pytest.fixture
def pair(dds_domain):
    first = DdsParticipant(dds_domain, CycloneSettings())
    second = DdsParticipant(dds_domain, CycloneSettings())
    yield first, second
    first.close()
    second.close()


def exchange(writers: list[tuple[RawWriter, bytes]], readers: list[RawReader]) -> list[bytes]:
    """Write each CDR once every writer is matched; the first sample each reader takes."""
    deadline = time.monotonic() + MATCH_TIMEOUT_S
    while any(w.entity.get_publication_matched_status().current_count < 1 for w, _ in writers):
        assert time.monotonic() < deadline, "readers and writers did not match"
        time.sleep(0.02)
    for writer, cdr in writers:
        assert writer.write(cdr) == 0
    received: dict[int, bytes] = {}
    while len(received) < len(readers):
        assert time.monotonic() < deadline, f"{len(readers) - len(received)} samples missing"
        for index, reader in enumerate(readers):
            if index not in received and (samples := reader.take()):
                received[index] = samples[0].data
        time.sleep(0.01)
    return [received[i] for i in range(len(readers))]


def sample_message(registry, type_name: str) -> dict:
    msg = normalize(registry.message(type_name), {}, now_ns=1)
    if type_name == "sensor_msgs/msg/PointCloud2":
        msg.update(
            width=3,
            height=1,
            point_step=4,
            row_step=12,
            data=bytes(range(12)),
            fields=[{"name": "x", "offset": 0, "datatype": 7, "count": 1}],
        )
    if type_name == "nav_msgs/msg/Path":
        pose = normalize(registry.message("geometry_msgs/msg/PoseStamped"), {}, now_ns=1)
        msg["poses"] = [pose, pose]
    if type_name == "sensor_msgs/msg/LaserScan":
        msg["ranges"] = np.arange(5, dtype=np.float32)
    return msg


def test_every_registered_message_type_round_trips_as_cdr(pair, registry):
    first, second = pair
    names = sorted(registry.typestore.fielddefs)
    writers, readers, sent = [], [], []
    for index, name in enumerate(names):
        spec = registry.message(name)
        data_type = first.types.message(spec)
        topic = topic_to_dds(f"/types/t{index}")
        cdr = to_cdr(registry, name, sample_message(registry, name))
        writers.append((first.writer(topic, data_type, DEFAULT), cdr))
        readers.append(second.reader(topic, second.types.message(spec), DEFAULT))
        sent.append(cdr)
    received = exchange(writers, readers)
    for name, cdr, got in zip(names, sent, received, strict=True):
        assert got == cdr, name
        from_cdr(registry, name, got)
    assert len(names) > 250


def test_service_parts_carry_the_request_header(pair, registry):
    first, second = pair
    spec = registry.service("std_srvs/srv/SetBool")
    topic = "rq/lock_gateRequest"
    writer = first.writer(topic, first.types.service_part(spec.request), SERVICES)
    reader = second.reader(topic, second.types.service_part(spec.request), SERVICES)
    assert writer.entity.topic.typename == "std_srvs::srv::dds_::SetBool_Request_"
    cdr = request_header.wrap(
        to_cdr(registry, spec.request.name, {"data": True}), RequestId(writer.instance_handle, 3)
    )
    (got,) = exchange([(writer, cdr)], [reader])
    request, body = request_header.unwrap(got)
    assert request == RequestId(writer.instance_handle, 3)
    assert from_cdr(registry, spec.request.name, body) == {"data": True}


def test_a_domain_left_by_its_last_participant_can_be_joined_again(dds_domain):
    for _ in range(2):  # Cyclone refuses a second domain with a live id (precondition)
        participants = [DdsParticipant(dds_domain, CycloneSettings()) for _ in range(2)]
        for participant in participants:
            participant.close()
