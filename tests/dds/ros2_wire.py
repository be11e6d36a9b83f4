"""ROS 2's DDS conventions, written by hand for the plain-cyclonedds peers (ros2_peer.py,
ros2_action_peer.py), with no riverbridge code: ROS 2's default QoS and rmw_cyclonedds_cpp's
services, a request topic `rq/<service>Request` and a reply topic `rr/<service>Reply` whose
samples lead with its request header (`guid`: the client's instance handle, `seq`), the two
endpoints of one client (or server) paired by the same `clientid=`/`serviceid=` user data.

The peers run as scripts, so their folder is on `sys.path` and they import this as `ros2_wire`.
"""

# No `from __future__ import annotations`: cyclonedds reads the field annotations as objects.
import time
from dataclasses import dataclass

import cyclonedds.idl.types as t
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

# ROS 2's default QoS: reliable, volatile, keep-last 10.
ROS2_DEFAULT_QOS = Qos(
    Policy.Reliability.Reliable(1_000_000_000),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(10),
)


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: t.int32
    nanosec: t.uint32


def service_server(
    participant: DomainParticipant, name: str, request: type, response: type, user_data: bytes
) -> tuple[DataReader, DataWriter]:
    """(request reader, reply writer) of a server of service `name`."""
    qos = Qos(*ROS2_DEFAULT_QOS, Policy.Userdata(data=user_data))
    reader = DataReader(participant, Topic(participant, f"rq{name}Request", request), qos)
    writer = DataWriter(participant, Topic(participant, f"rr{name}Reply", response), qos)
    return reader, writer


class ServiceClients:
    """Clients of `services` ((name, request type, response type), ...), one request writer
    and one reply reader each, all under one `user_data`; each is called by its name's last
    part (`send_goal` for `/fibonacci/_action/send_goal`)."""

    def __init__(
        self,
        participant: DomainParticipant,
        services: tuple[tuple[str, type, type], ...],
        user_data: bytes = b"clientid=peer.client;",
    ) -> None:
        qos = Qos(*ROS2_DEFAULT_QOS, Policy.Userdata(data=user_data))
        self.pairs = {}
        for name, request, response in services:
            writer = DataWriter(participant, Topic(participant, f"rq{name}Request", request), qos)
            reader = DataReader(participant, Topic(participant, f"rr{name}Reply", response), qos)
            self.pairs[name.rsplit("/", 1)[1]] = (writer, reader)
        first_writer = next(iter(self.pairs.values()))[0]
        self.guid = first_writer.get_instance_handle() & (2**64 - 1)

    def matched(self) -> bool:
        return all(
            writer.get_publication_matched_status().current_count
            and reader.get_subscription_matched_status().current_count
            for writer, reader in self.pairs.values()
        )

    def wait_matched(self, deadline_s: float) -> bool:
        """True once every server is matched, False if `deadline_s` (monotonic) passes."""
        while not self.matched():
            if time.monotonic() > deadline_s:
                return False
            time.sleep(0.05)
        return True

    def call(self, part: str, request, deadline_s: float):
        """The reply to `request` (its header's guid and seq), or TimeoutError."""
        writer, reader = self.pairs[part]
        writer.write(request)
        while time.monotonic() < deadline_s:
            for reply in reader.take(N=10):
                if reply.guid == request.guid and reply.seq == request.seq:
                    return reply
            time.sleep(0.02)
        raise TimeoutError(f"no {part} reply")
