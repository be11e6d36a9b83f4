"""Calls to a Fast DDS server (no request header, one request in flight): what goes on the
wire, read by a plain cyclonedds reader of the request topic. No server answers here, so the
second request waits, unless the first has gone unanswered for the stale limit."""

# No `from __future__ import annotations`: cyclonedds reads the field annotations as objects.
import time
from dataclasses import dataclass

import pytest
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from bridge.dds.cyclone_xml import CycloneSettings
from bridge.dds.outbox import Outbox, WriterThread
from bridge.dds.participant import DdsParticipant, DdsPlumbing, Pump
from bridge.dds.service_endpoints import ServiceClient

pytestmark = pytest.mark.slow

SETTLE_S = 1.5  # long enough for a written request to reach the reader on the loopback


@dataclass
class BareSetBoolRequest(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Request_"):
    data: bool  # Fast DDS's request: the fields alone, no rmw_cyclonedds header


def requests_seen(reader: DataReader, count: int, timeout_s: float) -> list[bool]:
    seen: list[bool] = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and len(seen) < count:
        seen.extend(sample.data for sample in reader.take(N=10))
        time.sleep(0.05)
    return seen


@pytest.mark.parametrize("stale", [False, True], ids=["in-flight-waits", "stale-gives-way"])
def test_requests_to_a_fast_dds_server_go_one_at_a_time(dds_domain, registry, stale):
    participant = DdsParticipant(dds_domain, CycloneSettings(), tuned=False)
    outbox, pump = Outbox(), Pump(participant)
    writer = WriterThread(outbox)
    writer.start()
    pump.start()
    peer = DomainParticipant(dds_domain)
    reliable = Qos(Policy.Reliability.Reliable(1_000_000_000), Policy.History.KeepLast(10))
    reader = DataReader(peer, Topic(peer, "rq/gateRequest", BareSetBoolRequest), reliable)
    dds = DdsPlumbing(participant, pump, outbox, registry)
    client = ServiceClient(dds, "/gate", "std_srvs/srv/SetBool", lambda *a: None, False)
    try:
        deadline = time.monotonic() + 30
        while not client.writer.entity.get_publication_matched_status().current_count:
            assert time.monotonic() < deadline, "the request reader never matched"
            time.sleep(0.05)
        if stale:
            client._stale_s = 0.0  # the first request counts as lost at once
        client.request({"data": True})
        client.request({"data": False})
        seen = requests_seen(reader, 2, SETTLE_S)
    finally:
        client.close()
        pump.stop()
        writer.stop()
        participant.close()
    assert seen == ([True, False] if stale else [True])
