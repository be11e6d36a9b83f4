"""ROS 2 names as they appear on the DDS wire (rmw_cyclonedds_cpp's conventions).

A ROS topic `/chatter` is the DDS topic `rt/chatter`; a service `/add` is the pair
`rq/addRequest` (requests) and `rr/addReply` (replies). A message type `sensor_msgs/msg/Imu`
is the DDS type `sensor_msgs::msg::dds_::Imu_`; a service's parts are
`pkg::srv::dds_::T_Request_` and `pkg::srv::dds_::T_Response_`. Everything here is pure.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

TOPIC_PREFIX = "rt"
REQUEST_PREFIX = "rq"
REPLY_PREFIX = "rr"
REQUEST_SUFFIX = "Request"
REPLY_SUFFIX = "Reply"
# ROS 2's own graph topic (node names and the endpoints each node owns).
DISCOVERY_TOPIC = "ros_discovery_info"
DISCOVERY_TYPE = "rmw_dds_common/msg/ParticipantEntitiesInfo"

Role = Literal["topic", "request", "reply"]


@dataclass(frozen=True)
class WireName:
    """What a DDS topic name means in ROS terms: a topic, or one half of a service."""

    role: Role
    ros_name: str  # absolute: "/chatter", "/add_two_ints"


def topic_to_dds(ros_name: str) -> str:
    """`/chatter` -> `rt/chatter` (ROS names are absolute here)."""
    return TOPIC_PREFIX + _absolute(ros_name)


def request_topic(service: str) -> str:
    """`/add` -> `rq/addRequest`."""
    return REQUEST_PREFIX + _absolute(service) + REQUEST_SUFFIX


def reply_topic(service: str) -> str:
    """`/add` -> `rr/addReply`."""
    return REPLY_PREFIX + _absolute(service) + REPLY_SUFFIX


def parse_dds_topic(dds_name: str) -> WireName | None:
    """The ROS meaning of a DDS topic name, or None for DDS-only topics (`DCPS…`, `ros_…`)."""
    prefix, slash, rest = dds_name.partition("/")
    if not slash or not rest or rest.startswith("/"):
        return None
    name = "/" + rest
    if prefix == TOPIC_PREFIX:
        return WireName("topic", name)
    if prefix == REQUEST_PREFIX and name.endswith(REQUEST_SUFFIX) and name != "/" + REQUEST_SUFFIX:
        return WireName("request", name[: -len(REQUEST_SUFFIX)])
    if prefix == REPLY_PREFIX and name.endswith(REPLY_SUFFIX) and name != "/" + REPLY_SUFFIX:
        return WireName("reply", name[: -len(REPLY_SUFFIX)])
    return None


def type_to_dds(type_name: str) -> str:
    """`sensor_msgs/msg/Imu` -> `sensor_msgs::msg::dds_::Imu_`;
    `std_srvs/srv/SetBool_Request` -> `std_srvs::srv::dds_::SetBool_Request_`."""
    package, kind, name = _three_parts(type_name)
    return f"{package}::{kind}::dds_::{name}_"


def type_from_dds(dds_type: str) -> str | None:
    """The inverse of `type_to_dds` (`pkg/kind/T`), or None if it is not a ROS 2 type name."""
    parts = dds_type.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_") or not parts[0]:
        return None
    if parts[1] not in ("msg", "srv", "action") or len(parts[3]) < 2:
        return None
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


def service_type_of_part(part_type: str) -> tuple[str, str] | None:
    """`pkg/srv/T_Request` -> (`pkg/srv/T`, "request"); `…_Response` -> "response"; also an
    action's own services (`pkg/action/T_SendGoal_Request` -> `pkg/action/T_SendGoal`)."""
    for suffix, which in (("_Request", "request"), ("_Response", "response")):
        if part_type.endswith(suffix) and ("/srv/" in part_type or "/action/" in part_type):
            return part_type[: -len(suffix)], which
    return None


# rcl_action's names: action `/fibonacci` is the services `/fibonacci/_action/send_goal`,
# `…/get_result`, `…/cancel_goal` and the topics `…/feedback`, `…/status`.
ACTION_INFIX = "/_action/"
SEND_GOAL_SUFFIX = "_SendGoal"


def action_part(action: str, part: str) -> str:
    """(`/fibonacci`, `send_goal`) -> `/fibonacci/_action/send_goal`."""
    return _absolute(action).rstrip("/") + ACTION_INFIX + part


def action_of_send_goal(service: str, service_type: str) -> tuple[str, str] | None:
    """(`/fibonacci/_action/send_goal`, `pkg/action/Fibonacci_SendGoal`) ->
    (`/fibonacci`, `pkg/action/Fibonacci`); None for any other service."""
    action, infix, part = service.rpartition(ACTION_INFIX)
    if not action or part != "send_goal" or not infix:
        return None
    if "/action/" not in service_type or not service_type.endswith(SEND_GOAL_SUFFIX):
        return None
    return action, service_type[: -len(SEND_GOAL_SUFFIX)]


def node_name(namespace: str, name: str) -> str:
    """ROS 2's fully qualified node name: (`/`, `talker`) -> `/talker`; (`/ns`, `t`) -> `/ns/t`."""
    return ("/" + namespace.strip("/")).rstrip("/") + "/" + name


def _absolute(name: str) -> str:
    return name if name.startswith("/") else "/" + name


def _three_parts(type_name: str) -> tuple[str, str, str]:
    parts = type_name.split("/")
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"{type_name!r} is not a pkg/kind/Type name")
    return parts[0], parts[1], parts[2]
