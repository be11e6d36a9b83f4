"""The DDS mirror's pure parts: wire names, QoS, the request header, the Cyclone XML, the
domain read as a ROS graph, the graph's remote half and the write queue."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.dds import discovery_info, naming, request_header
from bridge.dds.cyclone_xml import CycloneSettings, cyclone_xml
from bridge.dds.discovery import (
    DiscoveryDelta,
    DomainView,
    Endpoint,
    NodeEntities,
    participant_node,
)
from bridge.dds.discovery_info import ParticipantInfo
from bridge.dds.graph_sync import GraphSync
from bridge.dds.outbox import Outbox
from bridge.dds.qos import (
    DEFAULT,
    LATCHED,
    READER_DEPTH,
    QosError,
    QosProfile,
    advertised_profile,
    reader_profile,
    strongest,
    writer_profile,
)
from bridge.dds.request_header import RequestId
from schemas.codec_cdr import from_cdr, to_cdr

STRING = "std_msgs::msg::dds_::String_"
P1, P2 = bytes(range(12)) + b"\x00\x00\x01\xc1", bytes(range(1, 13)) + b"\x00\x00\x01\xc1"


def endpoint(
    n: int, participant: bytes, topic: str, dds_type: str, writer: bool, qos: QosProfile = DEFAULT
) -> Endpoint:
    return Endpoint(
        participant[:12] + n.to_bytes(4, "big"), participant, topic, dds_type, writer, qos
    )


def test_ros_names_map_to_rmw_cyclonedds_wire_names():
    assert naming.topic_to_dds("/chatter") == "rt/chatter"
    assert naming.topic_to_dds("/a/b") == "rt/a/b"
    assert naming.request_topic("/add") == "rq/addRequest"
    assert naming.reply_topic("/ns/add") == "rr/ns/addReply"
    assert naming.parse_dds_topic("rt/a/b") == naming.WireName("topic", "/a/b")
    assert naming.parse_dds_topic("rq/addRequest") == naming.WireName("request", "/add")
    assert naming.parse_dds_topic("rr/ns/addReply") == naming.WireName("reply", "/ns/add")
    for other in ("ros_discovery_info", "DCPSPublication", "rq/add", "rt/", "xx/a", "rt//a"):
        assert naming.parse_dds_topic(other) is None


def test_ros_types_map_to_dds_type_names():
    assert naming.type_to_dds("sensor_msgs/msg/Imu") == "sensor_msgs::msg::dds_::Imu_"
    assert (
        naming.type_to_dds("std_srvs/srv/SetBool_Request")
        == "std_srvs::srv::dds_::SetBool_Request_"
    )
    assert naming.type_from_dds("geometry_msgs::msg::dds_::Wrench_") == "geometry_msgs/msg/Wrench"
    assert naming.type_from_dds("std_srvs::srv::dds_::SetBool_Response_") == (
        "std_srvs/srv/SetBool_Response"
    )
    for other in ("Imu", "sensor_msgs::msg::Imu_", "a::b::dds_::C_", "a::msg::dds_::C"):
        assert naming.type_from_dds(other) is None
    assert naming.service_type_of_part("std_srvs/srv/SetBool_Request") == (
        "std_srvs/srv/SetBool",
        "request",
    )
    assert naming.service_type_of_part("std_msgs/msg/String") is None
    assert naming.node_name("/", "talker") == "/talker"
    assert naming.node_name("/ns/", "t") == "/ns/t"
    assert naming.node_name("", "t") == "/t"


def test_writer_qos_follows_ros2_defaults_latch_and_the_advertise_qos_object():
    assert writer_profile(False, None) == QosProfile(True, False, 10)
    assert writer_profile(True, None) == LATCHED == QosProfile(True, True, 1)
    assert writer_profile(False, {"reliability": "best_effort", "depth": 5}) == QosProfile(
        False, False, 5
    )
    assert writer_profile(False, {"durability": "transient_local", "history": "keep_all"}) == (
        QosProfile(True, True, 0)
    )
    for bad in (
        {"reliability": "sometimes"},
        {"depth": 0},
        {"depth": True},
        {"history": "keep_some"},
    ):
        with pytest.raises(QosError):
            writer_profile(False, bad)
    assert advertised_profile(True, {"reliability": "sometimes"}) == (
        LATCHED,
        "qos.reliability must be one of reliable, best_effort, best_available, "
        "system_default; got 'sometimes'",
    )
    assert advertised_profile(False, {"depth": 3}) == (QosProfile(depth=3), "")


def test_reader_qos_adapts_to_the_writers_it_must_match():
    best_effort, latched = QosProfile(False, False, 5), QosProfile(True, True, 1)
    assert reader_profile([]) == QosProfile(True, False, READER_DEPTH)
    assert reader_profile([DEFAULT, best_effort]).reliable is False
    assert reader_profile([latched]).transient_local is True
    assert reader_profile([latched, DEFAULT]).transient_local is False
    assert strongest([best_effort, latched]) == QosProfile(True, True, 5)
    assert strongest([DEFAULT, QosProfile(depth=0)]).depth == 0


def test_reader_qos_follows_what_subscribers_ask_for_else_adapts():
    best_effort = QosProfile(reliable=False)
    latched = QosProfile(transient_local=True, depth=1)
    asked = reader_profile([DEFAULT], [{"reliability": "best_effort", "depth": 100}])
    assert asked == QosProfile(False, False, 100)
    assert reader_profile([best_effort], [{"reliability": "reliable"}]).reliable is True
    assert (
        reader_profile(
            [DEFAULT], [{"reliability": "reliable"}, {"reliability": "best_effort"}]
        ).reliable
        is False
    )
    assert reader_profile([DEFAULT], [{"durability": "transient_local"}]).transient_local is True
    assert reader_profile([latched], [{"durability": "volatile"}]).transient_local is False
    adaptive = reader_profile([best_effort, latched], [{"reliability": "best_available"}])
    assert adaptive == reader_profile([best_effort, latched])
    with pytest.raises(QosError, match=r"qos\.reliability"):
        reader_profile([], [{"reliability": "sometimes"}])


def test_request_header_sits_between_encapsulation_and_fields(registry):
    body = to_cdr(registry, "std_srvs/srv/SetBool_Request", {"data": True})
    wrapped = request_header.wrap(body, RequestId(0x0102030405060708, 42))
    assert wrapped[:4] == body[:4] == b"\x00\x01\x00\x00"
    assert wrapped[4:12] == (0x0102030405060708).to_bytes(8, "little")
    assert wrapped[12:20] == (42).to_bytes(8, "little", signed=True)
    request, cdr = request_header.unwrap(wrapped)
    assert request == RequestId(0x0102030405060708, 42) and cdr == body
    assert from_cdr(registry, "std_srvs/srv/SetBool_Request", cdr) == {"data": True}
    big_endian = b"\x00\x00\x00\x00" + (7).to_bytes(8, "big") + (9).to_bytes(8, "big")
    assert request_header.unwrap(big_endian)[0] == RequestId(7, 9)
    with pytest.raises(ValueError):
        request_header.unwrap(b"\x00\x01\x00\x00abc")


def test_cyclone_xml_keeps_dds_on_the_named_interface_without_multicast():
    loopback = ET.fromstring(cyclone_xml(CycloneSettings()))
    assert loopback.find("Domain/General/Interfaces/NetworkInterface").get("name") == "lo"
    assert loopback.find("Domain/General/AllowMulticast").text == "false"
    assert [p.get("address") for p in loopback.iter("Peer")] == ["127.0.0.1"]
    assert loopback.find("Domain/Discovery/ParticipantIndex").text == "auto"
    veth = ET.fromstring(cyclone_xml(CycloneSettings("veth-a", ("10.0.0.2",), "spdp"), False))
    assert veth.find("Domain/General/Interfaces/NetworkInterface").get("name") == "veth-a"
    assert veth.find("Domain/General/AllowMulticast").text == "spdp"
    assert [p.get("address") for p in veth.iter("Peer")] == ["10.0.0.2"]
    assert veth.find("Domain/Internal") is None
    for bad in ({"interface": 'lo"/><x'}, {"peers": ('1.2.3.4"',)}, {"multicast": "maybe"}):
        with pytest.raises(ValueError):
            CycloneSettings(**bad)


def test_domain_view_names_endpoints_after_ros_discovery_info_nodes():
    view = DomainView()
    talker_writer = endpoint(1, P1, "rt/chatter", "std_msgs::msg::dds_::String_", True)
    listener = endpoint(2, P2, "rt/chatter", "std_msgs::msg::dds_::String_", False)
    odd_type = endpoint(3, P2, "rt/chatter", "other::msg::dds_::String_", True)
    request = endpoint(4, P1, "rq/setRequest", "std_srvs::srv::dds_::SetBool_Request_", False)
    reply = endpoint(5, P1, "rr/setReply", "std_srvs::srv::dds_::SetBool_Response_", True)
    plain = endpoint(6, P2, "plain_dds_topic", "Whatever", True)
    view.apply(
        DiscoveryDelta(
            frozenset({P1, P2}), (talker_writer, listener, odd_type, request, reply, plain)
        )
    )
    view.update_nodes(
        P1,
        (
            NodeEntities(
                "/talker", frozenset({request.guid}), frozenset({talker_writer.guid, reply.guid})
            ),
        ),
    )
    topics = view.topics()
    assert list(topics) == ["/chatter"]
    assert topics["/chatter"].type_name == "std_msgs/msg/String"
    assert topics["/chatter"].publishers == {"/talker": [DEFAULT]}
    assert topics["/chatter"].subscribers == {participant_node(P2)}
    assert view.services()["/set"].node == "/talker"
    assert view.services()["/set"].type_name == "std_srvs/srv/SetBool"
    assert view.writer_node(talker_writer.guid) == "/talker"
    assert view.writer_node(b"unknown") is None
    assert view.announced_nodes() == {"/talker"}
    assert view.topics() is topics  # unchanged: not rebuilt
    view.apply(DiscoveryDelta(participants_gone=frozenset({P1}), endpoints_gone=frozenset()))
    assert view.node_info == {} and view.services() == {}
    assert view.endpoints == [listener, odd_type, plain]  # P1's went with it


def test_domain_view_takes_discovery_by_delta_and_rebuilds_the_graph_once_per_change():
    view = DomainView()
    writer = endpoint(1, P1, "rt/chatter", "std_msgs::msg::dds_::String_", True)
    assert view.apply(DiscoveryDelta(frozenset({P1}), (writer,)))
    first = view.topics()
    assert first["/chatter"].publishers == {participant_node(P1): [DEFAULT]}
    assert not view.apply(DiscoveryDelta(endpoints=(writer,)))  # announced again: no change
    assert view.topics() is first
    reliable = Endpoint(writer.guid, P1, writer.dds_topic, writer.dds_type, True, LATCHED)
    assert view.apply(DiscoveryDelta(endpoints=(reliable,)))  # its QoS changed: replaced
    assert view.topics()["/chatter"].publishers == {participant_node(P1): [LATCHED]}
    assert view.update_nodes(P1, (NodeEntities("/talker"),))
    assert not view.update_nodes(P1, (NodeEntities("/talker"),))
    assert list(view.topics()["/chatter"].publishers) == ["/talker"]
    assert not view.apply(DiscoveryDelta(endpoints_gone=frozenset({b"never seen"})))
    assert view.apply(DiscoveryDelta(endpoints_gone=frozenset({writer.guid})))
    assert view.topics() == {} and view.writer_node(writer.guid) is None
    assert view.announced_nodes() == {"/talker"}  # the node stays while its participant does
    assert view.apply(DiscoveryDelta(participants_gone=frozenset({P1})))
    assert view.announced_nodes() == set() and view.participants == set()
    assert not DiscoveryDelta()


def test_domain_view_names_participants_whose_ros_discovery_info_has_not_come():
    view = DomainView()
    info = "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
    announcer = endpoint(1, P1, "ros_discovery_info", info, True)
    view.apply(DiscoveryDelta(frozenset({P1, P2}), (announcer,)))
    view.apply(DiscoveryDelta(endpoints=(endpoint(2, P2, "ros_discovery_info", info, False),)))
    assert view.unannounced() == {P1}  # P2 only reads it
    view.update_nodes(P1, (NodeEntities("/talker"),))
    assert view.unannounced() == set()
    view.apply(DiscoveryDelta(endpoints=(endpoint(3, P2, "ros_discovery_info", info, True),)))
    assert view.unannounced() == {P2}
    view.apply(DiscoveryDelta(endpoints=(endpoint(4, P2, "rt/chatter", STRING, True),)))
    assert list(view.topics()) == ["/chatter"]
    view.hold(frozenset({P2}))  # its node name is on the way: not listed yet
    assert view.topics() == {}
    view.hold(frozenset())
    assert list(view.topics()) == ["/chatter"]
    view.apply(DiscoveryDelta(participants_gone=frozenset({P2})))
    assert view.unannounced() == set()


class CountingGraph:
    """The real core, counting the graph calls GraphSync makes."""

    def __init__(self, core: BridgeCore) -> None:
        self.core, self.calls = core, 0

    def __getattr__(self, name: str):
        def call(*args):
            self.calls += 1
            return getattr(self.core, name)(*args)

        return call


def test_graph_sync_changes_the_graph_by_the_delta_and_skips_an_unchanged_domain(registry):
    graph, sync, view = (
        CountingGraph(BridgeCore(BridgeConfig(), registry)),
        GraphSync(),
        DomainView(),
    )
    string = "std_msgs::msg::dds_::String_"
    view.apply(
        DiscoveryDelta(
            endpoints=tuple(endpoint(n, P1, f"rt/t{n}", string, True) for n in range(30))
        )
    )
    sync.apply(graph, view.topics(), set())
    assert graph.calls == 30 and {f"/t{n}" for n in range(30)} <= set(graph.core.state.graph.topics)
    sync.apply(graph, view.topics(), set())
    assert graph.calls == 30  # nothing changed: no graph call
    view.apply(DiscoveryDelta(endpoints=(endpoint(99, P1, "rt/late", string, False),)))
    sync.apply(graph, view.topics(), set())
    assert graph.calls == 31  # the one new subscriber
    assert graph.core.state.graph.topics["/late"].subscribers == {participant_node(P1)}


def test_graph_sync_adds_and_removes_remote_endpoints_but_never_local_ones(registry):
    core = BridgeCore(BridgeConfig(), registry)  # GraphSync changes the graph by core calls
    graph, sync, view = core.state.graph, GraphSync(), DomainView()
    graph.add_publisher("/chatter", "/rosbridge_client_1", None, latch=False)
    graph.declare_type("/chatter", "std_msgs/msg/String")
    remote = (
        endpoint(1, P1, "rt/chatter", "std_msgs::msg::dds_::String_", True),
        endpoint(2, P1, "rt/odom", "nav_msgs::msg::dds_::Odometry_", False),
        endpoint(3, P1, "rt/clash", "std_msgs::msg::dds_::Bool_", True),
    )
    view.apply(DiscoveryDelta(frozenset({P1}), remote))
    view.update_nodes(P1, (NodeEntities("/remote"),))
    graph.declare_type("/clash", "std_msgs/msg/String")
    graph.add_subscriber("/clash", "/rosbridge_client_1")
    sync.apply(core, view.topics(), {"/rosbridge_client_1"})
    assert set(graph.topics["/chatter"].publishers) == {"/rosbridge_client_1", "/remote"}
    assert graph.topics["/odom"].subscribers == {"/remote"}
    assert graph.topics["/odom"].type_name == "nav_msgs/msg/Odometry"
    assert "/remote" not in graph.topics["/clash"].publishers  # type conflict: not listed
    view.apply(DiscoveryDelta(endpoints_gone=frozenset(e.guid for e in remote)))
    sync.apply(core, view.topics(), {"/rosbridge_client_1"})
    assert set(graph.topics["/chatter"].publishers) == {"/rosbridge_client_1"}
    assert "/odom" not in graph.topics


def test_outbox_keeps_order_and_drops_the_oldest_of_a_full_stream():
    outbox, done = Outbox(max_items=2, max_bytes=100), []
    for n in range(4):
        outbox.put("imu", lambda n=n: done.append(("imu", n)), size=1)
    for n in range(3):
        outbox.put("scan", lambda n=n: done.append(("scan", n)), size=60)
    outbox.put("huge", lambda: done.append(("huge", 0)), size=500)  # alone: kept
    while (job := outbox.get(timeout_s=0)) is not None:
        job()
    assert done == [("imu", 2), ("imu", 3), ("scan", 2), ("huge", 0)]
    assert outbox.dropped == {"imu": 2, "scan": 2}
    outbox.close()
    assert outbox.get(timeout_s=0) is None


def test_discovery_info_layouts_per_distribution(registry):
    """Jazzy's bytes are rosbags' own CDR of the message; Humble's GIDs take 24 bytes."""
    node = NodeEntities("/ns/talker", frozenset({bytes(range(16))}), frozenset())
    info = ParticipantInfo(bytes(range(100, 116)), (node,))
    jazzy = discovery_info.encode(info, "jazzy")
    canonical = {
        "gid": {"data": info.participant},
        "node_entities_info_seq": [
            {
                "node_namespace": "/ns",
                "node_name": "talker",
                "reader_gid_seq": [{"data": bytes(range(16))}],
                "writer_gid_seq": [],
            }
        ],
    }
    assert jazzy == to_cdr(registry, "rmw_dds_common/msg/ParticipantEntitiesInfo", canonical)
    humble = discovery_info.encode(info, "humble")
    assert len(humble) == len(jazzy) + 8 + 8  # the participant's and the reader's GID
    assert discovery_info.decode(humble, "humble") == info
    assert discovery_info.decode(jazzy, "kilted") == info
    with pytest.raises(ValueError):
        discovery_info.decode(jazzy, "humble")
