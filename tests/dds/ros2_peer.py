"""A plain Cyclone DDS participant that talks like a ROS 2 node (no riverbridge code here).

It declares its types by hand, the way ROS 2's rosidl generates them for DDS
(`sensor_msgs::msg::dds_::Imu_` ...), and uses ROS 2's topic names (`rt/<topic>`) and default
QoS (reliable, volatile, keep-last 10). Run it with CYCLONEDDS_URI set: the test passes a
configuration that keeps DDS on the loopback.

usage:
  python3 ros2_peer.py DOMAIN imu COUNT TIMEOUT_S
      take COUNT sensor_msgs/msg/Imu samples from rt/imu/data; decode each one's CDR with
      rosbags and print them as one JSON line.
  python3 ros2_peer.py DOMAIN wrench SECONDS FORCE_X
      publish geometry_msgs/msg/Wrench (surge force FORCE_X) on rt/cmd_wrench at 10 Hz.
  python3 ros2_peer.py DOMAIN call SERVICE TIMEOUT_S
      call std_srvs/srv/SetBool SERVICE (data: true) the way rmw_cyclonedds_cpp does: a
      request on rq/<SERVICE>Request led by the request header (the writer's instance handle,
      a sequence number), the reply taken from rr/<SERVICE>Reply by that header.
"""

# No `from __future__ import annotations`: cyclonedds reads the field annotations as objects.
import json
import sys
import time
from dataclasses import dataclass

import cyclonedds.idl.types as t
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from ros2_wire import ROS2_DEFAULT_QOS, ServiceClients, Time
from rosbags.typesys import Stores, get_typestore


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: t.float64
    y: t.float64
    z: t.float64
    w: t.float64


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: t.float64
    y: t.float64
    z: t.float64


@dataclass
class Imu(IdlStruct, typename="sensor_msgs::msg::dds_::Imu_"):
    header: Header
    orientation: Quaternion
    orientation_covariance: t.array[t.float64, 9]
    angular_velocity: Vector3
    angular_velocity_covariance: t.array[t.float64, 9]
    linear_acceleration: Vector3
    linear_acceleration_covariance: t.array[t.float64, 9]


@dataclass
class Wrench(IdlStruct, typename="geometry_msgs::msg::dds_::Wrench_"):
    force: Vector3
    torque: Vector3


@dataclass
class SetBoolRequest(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Request_"):
    guid: t.uint64  # rmw_cyclonedds_cpp's cdds_request_header_t, then the request's fields
    seq: t.int64
    data: bool


@dataclass
class SetBoolResponse(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Response_"):
    guid: t.uint64
    seq: t.int64
    success: bool
    message: str


def take_imu(participant: DomainParticipant, count: int, timeout_s: float) -> dict:
    reader = DataReader(participant, Topic(participant, "rt/imu/data", Imu), ROS2_DEFAULT_QOS)
    store = get_typestore(Stores.ROS2_JAZZY)
    decoded = []
    deadline = time.monotonic() + timeout_s
    while len(decoded) < count and time.monotonic() < deadline:
        for sample in reader.take(N=count):
            msg = store.deserialize_cdr(sample.serialize(), "sensor_msgs/msg/Imu")
            decoded.append(
                {
                    "frame_id": msg.header.frame_id,
                    "stamp_ns": msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
                    "accel_z": msg.linear_acceleration.z,
                    "covariance_length": len(msg.orientation_covariance),
                }
            )
        time.sleep(0.01)
    return {"ok": len(decoded) >= count, "messages": decoded[:count]}


def publish_wrench(participant: DomainParticipant, seconds: float, force_x: float) -> dict:
    writer = DataWriter(participant, Topic(participant, "rt/cmd_wrench", Wrench), ROS2_DEFAULT_QOS)
    sent = 0
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        writer.write(Wrench(Vector3(force_x, 0.0, 0.0), Vector3(0.0, 0.0, 0.0)))
        sent += 1
        time.sleep(0.1)
    return {"ok": True, "sent": sent}


def call_set_bool(participant: DomainParticipant, service: str, timeout_s: float) -> dict:
    # The request writer and reply reader share the user data that pairs them.
    client = ServiceClients(
        participant, ((service, SetBoolRequest, SetBoolResponse),), b"clientid=peer.1;"
    )
    deadline = time.monotonic() + timeout_s
    client.wait_matched(deadline)  # unmatched at the deadline: written anyway, no reply
    part = service.rsplit("/", 1)[1]
    try:
        reply = client.call(part, SetBoolRequest(guid=client.guid, seq=1, data=True), deadline)
    except TimeoutError:
        return {"ok": False, "reason": "no reply"}
    return {"ok": True, "success": reply.success, "message": reply.message}


def main(argv: list[str]) -> int:
    domain, mode, *args = argv
    participant = DomainParticipant(int(domain))
    if mode == "imu":
        result = take_imu(participant, int(args[0]), float(args[1]))
    elif mode == "wrench":
        result = publish_wrench(participant, float(args[0]), float(args[1]))
    elif mode == "call":
        result = call_set_bool(participant, args[0], float(args[1]))
    else:
        result = {"ok": False, "reason": f"unknown mode {mode}"}
    print(json.dumps(result), flush=True)
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
