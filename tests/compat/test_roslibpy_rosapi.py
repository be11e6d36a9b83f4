"""roslibpy's rosapi helpers against the bridge's own rosapi services (protocol §9).

The graph is seeded by other roslibpy connections (an advertised topic, a provided service)
so every answer has something specific to contain.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest
import roslibpy

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint

TOPIC = "/compat/chatter"
SERVICE = "/compat/set_flag"


@dataclass(frozen=True)
class SeededGraph:
    """A roslibpy connection to query with, plus the connections that populate the graph."""

    ros: roslibpy.Ros
    publisher: roslibpy.Ros
    provider: roslibpy.Ros


@pytest.fixture(scope="module")
def graph(module_bridge: BridgeEndpoint) -> Iterator[SeededGraph]:
    """Seeded once: every test here only reads the graph."""
    host, port = module_bridge.host, module_bridge.port
    with rp.trapped_roslibpy_logs() as trap:
        publisher, provider, ros = (rp.connect(host, port) for _ in range(3))
        roslibpy.Topic(publisher, TOPIC, "std_msgs/String").advertise()
        roslibpy.Service(provider, SERVICE, "std_srvs/SetBool").advertise(lambda req, res: True)
        rp.barrier(publisher)
        rp.barrier(provider)
        yield SeededGraph(ros, publisher, provider)
        for connection in (ros, publisher, provider):
            rp.close(connection)
        assert not trap.errors(), "roslibpy logged errors:\n" + "\n".join(trap.errors())


def with_callback(start) -> Any:
    """Run a roslibpy helper in callback form (some have no timeout when blocking)."""
    done, box = threading.Event(), []

    def finish(value: Any) -> None:
        box.append(value)
        done.set()

    start(finish, finish)
    assert done.wait(rp.WAIT_TIMEOUT_S), "roslibpy rosapi helper got no answer"
    return box[0]


def test_get_topics_lists_advertised_topic_and_rosout(graph: SeededGraph) -> None:
    topics = graph.ros.get_topics()
    assert TOPIC in topics
    assert "/rosout" in topics


def test_get_topic_type_reports_ros2_type_name(graph: SeededGraph) -> None:
    assert graph.ros.get_topic_type(TOPIC) == "std_msgs/msg/String"
    assert graph.ros.get_topic_type("/rosout") == "rcl_interfaces/msg/Log"


def test_get_services_lists_client_service_and_rosapi(graph: SeededGraph) -> None:
    services = graph.ros.get_services()
    assert SERVICE in services
    assert "/rosapi/topics" in services


def test_get_service_type_reports_ros2_srv_name(graph: SeededGraph) -> None:
    assert graph.ros.get_service_type(SERVICE) == "std_srvs/srv/SetBool"


def test_nodes_and_node_details_show_who_publishes_and_serves(graph: SeededGraph) -> None:
    nodes = dict(with_callback(lambda ok, err: graph.ros.get_nodes(ok, err)))
    assert nodes["nodes"], nodes
    assert all(isinstance(node, str) and node.startswith("/") for node in nodes["nodes"])

    details = {node: graph.ros.get_node_details(node) for node in nodes["nodes"]}
    for detail in details.values():
        assert set(detail) == {"services", "subscribing", "publishing"}
    assert any(TOPIC in detail["publishing"] for detail in details.values()), details
    assert any(SERVICE in detail["services"] for detail in details.values()), details


def typedefs_by_type(details: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {typedef["type"]: typedef for typedef in details["typedefs"]}


def test_message_details_typedef_format(graph: SeededGraph) -> None:
    details = graph.ros.get_message_details("geometry_msgs/PoseStamped")
    typedefs = typedefs_by_type(details)

    assert details["typedefs"][0]["type"] == "geometry_msgs/PoseStamped"
    top = typedefs["geometry_msgs/PoseStamped"]
    assert top["fieldnames"] == ["header", "pose"]
    assert top["fieldtypes"] == ["std_msgs/Header", "geometry_msgs/Pose"]
    assert top["fieldarraylen"] == [-1, -1]
    assert typedefs["builtin_interfaces/Time"]["fieldnames"] == ["sec", "nanosec"]
    assert typedefs["builtin_interfaces/Time"]["fieldtypes"] == ["int32", "uint32"]
    assert typedefs["geometry_msgs/Point"]["fieldtypes"] == ["double", "double", "double"]
    for typedef in typedefs.values():
        count = len(typedef["fieldnames"])
        for key in ("fieldtypes", "fieldarraylen", "examples"):
            assert len(typedef[key]) == count, (typedef["type"], key)
        assert len(typedef["constnames"]) == len(typedef["constvalues"])
        for field_type in typedef["fieldtypes"]:
            assert "/" not in field_type or field_type in typedefs, field_type


def test_message_details_array_lengths(graph: SeededGraph) -> None:
    """-1 scalar, 0 sequence, N fixed-size array (rosapi TypeDef convention)."""
    imu = typedefs_by_type(graph.ros.get_message_details("sensor_msgs/Imu"))["sensor_msgs/Imu"]
    lengths = dict(zip(imu["fieldnames"], imu["fieldarraylen"], strict=True))
    types = dict(zip(imu["fieldnames"], imu["fieldtypes"], strict=True))
    assert lengths["orientation_covariance"] == 9
    assert types["orientation_covariance"] == "double"
    assert lengths["orientation"] == -1

    cloud = typedefs_by_type(graph.ros.get_message_details("sensor_msgs/msg/PointCloud2"))
    fields = cloud["sensor_msgs/PointCloud2"]
    lengths = dict(zip(fields["fieldnames"], fields["fieldarraylen"], strict=True))
    types = dict(zip(fields["fieldnames"], fields["fieldtypes"], strict=True))
    assert lengths["fields"] == 0 and types["fields"] == "sensor_msgs/PointField"
    assert lengths["data"] == 0
    assert "sensor_msgs/PointField" in cloud


def test_message_details_of_an_empty_message_has_no_fields(graph: SeededGraph) -> None:
    """std_msgs/Empty declares no fields; the IDL placeholder member is not a field."""
    [empty] = graph.ros.get_message_details("std_msgs/Empty")["typedefs"]
    assert empty["type"] == "std_msgs/Empty"
    assert empty["fieldnames"] == [] and empty["fieldtypes"] == []
