"""The Foxglove translator without a socket: framing, the channel table, one client's session,
the connection-graph diff and the asset allow-list (bridge/foxglove/)."""

from __future__ import annotations

import struct
from pathlib import Path

import orjson
import pytest

from bridge.effects import Send
from bridge.foxglove import wire
from bridge.foxglove.assets import AssetDirectory
from bridge.foxglove.channels import ChannelTable
from bridge.foxglove.graph_view import graph_changes
from bridge.foxglove.session import FoxgloveDelivery, FoxgloveSession
from bridge.outgoing import CBOR_RAW, ControlMessage, Delivery, RawFrame, TopicMessage
from schemas.codec_cdr import from_cdr, to_cdr
from schemas.registry import TypeRegistry

WRENCH = "geometry_msgs/msg/Wrench"
IMU = "sensor_msgs/msg/Imu"


@pytest.fixture(scope="module")
def registry() -> TypeRegistry:
    return TypeRegistry.with_defaults()


@pytest.fixture
def table(registry: TypeRegistry) -> ChannelTable:
    table = ChannelTable(registry)
    table.reconcile_topics({"/imu": IMU, "/cmd": WRENCH, "/odd": "no_pkg/msg/Unknown"})
    table.reconcile_services({"/rosapi/get_time": "rosapi_msgs/srv/GetTime"})
    return table


def subscribe(sub_id: int, channel_id: int) -> str:
    request = {"id": sub_id, "channelId": channel_id}
    return orjson.dumps({"op": "subscribe", "subscriptions": [request]}).decode()


def statuses(frames: list[bytes]) -> list[str]:
    return [orjson.loads(f)["message"] for f in frames if orjson.loads(f)["op"] == "status"]


# -- wire ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        ("{", "not JSON"),
        ("[1, 2]", "expected a JSON object"),
        ('{"op": "nope"}', "unknown op: 'nope'"),
        ('{"op": "subscribe", "subscriptions": [{"id": -1, "channelId": 1}]}', "malformed"),
        ('{"op": "fetchAsset", "uri": "x"}', "requestId"),
    ],
)
def test_bad_text_ops_are_named(data: str, problem: str) -> None:
    with pytest.raises(wire.FoxgloveWireError, match=problem):
        wire.parse_text(data)


@pytest.mark.parametrize(
    ("data", "problem"),
    [
        (b"", "empty"),
        (b"\x09abc", "unknown binary opcode 9"),
        (b"\x01\x00", "binary opcode 1"),
        (b"\x02" + struct.pack("<III", 1, 2, 99) + b"cdr", "shorter than its encoding"),
        (b"\x03\x07" + bytes(17), "malformed playback control"),
    ],
)
def test_bad_binary_frames_are_named(data: bytes, problem: str) -> None:
    with pytest.raises(wire.FoxgloveWireError, match=problem):
        wire.parse_binary(data)


def test_binary_layouts_round_trip() -> None:
    request = b"\x02" + struct.pack("<III", 5, 9, 3) + b"cdr" + b"\x00\x01\x00\x00"
    assert wire.parse_binary(request) == wire.ServiceCallRequest(5, 9, "cdr", b"\x00\x01\x00\x00")
    control = b"\x03" + struct.pack("<BfBQI", 1, 2.0, 1, 123, 2) + b"id"
    assert wire.parse_binary(control) == wire.PlaybackControlRequest(False, 2.0, 123, "id")
    assert wire.message_data_header(7, 11) == b"\x01" + struct.pack("<IQ", 7, 11)
    state = wire.playback_state(wire.PAUSED, 42, 1.5, True, "r")
    assert state == struct.pack("<BBQfBI", 5, 1, 42, 1.5, 1, 1) + b"r"
    assert wire.fetch_asset_response(3, None, "no") == struct.pack("<BIBI", 4, 3, 1, 2) + b"no"


# -- channels ---------------------------------------------------------------------------------


def test_channels_follow_the_graph_with_fresh_ids(registry: TypeRegistry) -> None:
    table = ChannelTable(registry)
    first = table.reconcile_topics({"/imu": IMU, "/odd": "no_pkg/msg/Unknown"})
    assert [c["topic"] for c in first.added] == ["/imu"]  # an unknown type gets no channel
    advert = first.added[0]
    assert advert["encoding"] == "cdr" and advert["schemaEncoding"] == "ros2msg"
    assert advert["schema"] == registry.full_text(IMU)
    assert table.reconcile_topics({"/imu": IMU}).added == []
    gone = table.reconcile_topics({})
    assert gone.removed == [advert["id"]]
    again = table.reconcile_topics({"/imu": IMU})
    assert again.added[0]["id"] != advert["id"]  # never reused


def test_services_carry_request_and_response_schemas(table: ChannelTable) -> None:
    (advert,) = table.service_adverts()
    assert advert["type"] == "rosapi_msgs/srv/GetTime"
    assert advert["request"]["schemaName"] == "rosapi_msgs/srv/GetTime_Request"
    assert "builtin_interfaces/Time time" in advert["response"]["schema"]


# -- session ----------------------------------------------------------------------------------


def test_subscribe_becomes_a_cbor_raw_subscription(table: ChannelTable, registry) -> None:
    session = FoxgloveSession(1, table, registry)
    channel = table.by_topic["/imu"]
    reply = session.receive(
        orjson.dumps(
            {
                "op": "subscribe",
                "subscriptions": [{"id": 4, "channelId": channel.id}, {"id": 5, "channelId": 999}],
            }
        ).decode()
    )
    assert reply.ops == [
        {"op": "subscribe", "id": "fg:4", "topic": "/imu", "type": IMU, "compression": CBOR_RAW}
    ]
    assert statuses(reply.frames) == ["unknown channel 999"]
    again = session.receive(subscribe(4, channel.id))
    assert statuses(again.frames) == ["subscription 4 already exists"]
    assert session.receive('{"op": "unsubscribe", "subscriptionIds": [4]}').ops == [
        {"op": "unsubscribe", "id": "fg:4", "topic": "/imu"}
    ]


def test_a_delivery_carries_the_shared_cdr_bytes(table: ChannelTable, registry) -> None:
    session = FoxgloveSession(1, table, registry)
    channel = table.by_topic["/cmd"]
    session.receive(subscribe(2, channel.id))
    msg = {"force": {"x": 1.5, "y": 0.0, "z": 0.0}, "torque": {"x": 0.0, "y": 0.0, "z": 2.0}}
    message = TopicMessage("/cmd", WRENCH, msg, 123_000, registry)
    cbor_raw = message.frame(CBOR_RAW, "/cmd")  # a rosbridge cbor-raw subscriber first
    (send,) = session.outgoing(Send(1, Delivery(message, "/cmd", CBOR_RAW), "/cmd"))
    assert isinstance(send.item, FoxgloveDelivery) and send.drop_key == "/cmd"
    frame = send.item.frame()
    assert not frame.text
    assert frame.data[:13] == wire.message_data_header(2, 123_000)
    assert frame.data[13:] == message.cdr and message.cdr in cbor_raw.data  # encoded once
    assert from_cdr(registry, WRENCH, frame.data[13:])["torque"]["z"] == 2.0


def test_client_publish_decodes_cdr_and_json(table: ChannelTable, registry) -> None:
    session = FoxgloveSession(1, table, registry)
    advertise = {
        "op": "advertise",
        "channels": [
            {"id": 1, "topic": "/cmd", "encoding": "cdr", "schemaName": WRENCH},
            {"id": 2, "topic": "/cmd_json", "encoding": "json", "schemaName": WRENCH},
            {"id": 3, "topic": "/x", "encoding": "protobuf", "schemaName": WRENCH},
            {"id": 4, "topic": "/y", "encoding": "cdr", "schemaName": "nope/msg/Nope"},
        ],
    }
    reply = session.receive(orjson.dumps(advertise).decode())
    assert [op["topic"] for op in reply.ops] == ["/cmd", "/cmd_json"]
    assert len(statuses(reply.frames)) == 2
    msg = {"force": {"x": 3.0, "y": 0.0, "z": 0.0}, "torque": {"x": 0.0, "y": 0.0, "z": 0.0}}
    cdr = to_cdr(registry, WRENCH, msg)
    (op,) = session.receive(b"\x01" + struct.pack("<I", 1) + cdr).ops
    assert op["topic"] == "/cmd" and op["msg"]["force"]["x"] == 3.0
    (op,) = session.receive(b"\x01" + struct.pack("<I", 2) + orjson.dumps(msg)).ops
    assert op == {"op": "publish", "topic": "/cmd_json", "msg": msg}
    bad = session.receive(b"\x01" + struct.pack("<I", 1) + b"\x00\x01")
    assert bad.ops == [] and "undecodable cdr message" in statuses(bad.frames)[0]


def test_service_calls_and_their_answers(table: ChannelTable, registry) -> None:
    session = FoxgloveSession(1, table, registry)
    service = table.services_by_name["/rosapi/get_time"]
    request = b"\x02" + struct.pack("<III", service.id, 7, 3) + b"cdr" + b"\x00\x01\x00\x00\x00"
    (op,) = session.receive(request).ops
    assert op["op"] == "call_service" and op["service"] == "/rosapi/get_time"
    answer = {
        "op": "service_response",
        "id": op["id"],
        "result": True,
        "values": {"time": {"sec": 5, "nanosec": 6}},
    }
    (send,) = session.outgoing(Send(1, ControlMessage(answer)))
    assert isinstance(send.item, RawFrame)
    data = send.item.frame().data
    assert data[:1] == b"\x03" and struct.unpack_from("<III", data, 1) == (service.id, 7, 3)
    response = from_cdr(registry, service.response_type, data[16:])
    assert response["time"] == {"sec": 5, "nanosec": 6}
    (op,) = session.receive(request.replace(struct.pack("<I", 7), struct.pack("<I", 8), 1)).ops
    failed = {"op": "service_response", "id": op["id"], "result": False, "values": "it broke"}
    (send,) = session.outgoing(Send(1, ControlMessage(failed)))
    assert orjson.loads(send.item.frame().data) == {
        "op": "serviceCallFailure",
        "serviceId": service.id,
        "callId": 8,
        "message": "it broke",
    }


def test_every_action_passes_the_one_authorization_point(table: ChannelTable, registry) -> None:
    asked: list[tuple[str, str]] = []

    def permit(action: str, name: str) -> str | None:
        asked.append((action, name))
        return "not for you"

    session = FoxgloveSession(1, table, registry, permit)
    channel = table.by_topic["/imu"]
    frames = [
        subscribe(1, channel.id),
        orjson.dumps(
            {
                "op": "advertise",
                "channels": [{"id": 1, "topic": "/cmd", "encoding": "cdr", "schemaName": WRENCH}],
            }
        ).decode(),
        '{"op": "setParameters", "parameters": [{"name": "p", "value": 1}]}',
        '{"op": "fetchAsset", "uri": "package://a/b.stl", "requestId": 1}',
    ]
    for frame in frames:
        reply = session.receive(frame)
        assert reply.ops == [] and reply.asset is None
        assert statuses(reply.frames)[0].endswith("not for you")
    assert [a for a, _ in asked] == ["subscribe", "publish", "set_param", "fetch_asset"]


def test_parameter_values_are_json_typed(table: ChannelTable, registry) -> None:
    session = FoxgloveSession(1, table, registry)
    reply = session.receive(
        '{"op": "setParameters", "id": "s", "parameters": [{"name": "/a:b", "value": [1, 2]}]}'
    )
    assert reply.ops[0]["args"] == {"name": "/a:b", "value": "[1,2]"}
    assert reply.parameters_after == (["/a:b"], "s")
    values = orjson.loads(session.parameter_values([], {"/a:b": "[1,2]", "/c": '"x"'}, "s"))
    assert values == {
        "op": "parameterValues",
        "id": "s",
        "parameters": [{"name": "/a:b", "value": [1, 2]}, {"name": "/c", "value": "x"}],
    }


# -- graph and assets -------------------------------------------------------------------------


def test_connection_graph_updates_say_only_what_changed() -> None:
    empty = {"published": {}, "subscribed": {}, "services": {}}
    one = {"published": {"/a": ["/n1"]}, "subscribed": {}, "services": {"/s": ["/n2"]}}
    full = orjson.loads(graph_changes({}, one) or b"")
    assert full["publishedTopics"] == [{"name": "/a", "publisherIds": ["/n1"]}]
    assert graph_changes(one, one) is None
    gone = orjson.loads(graph_changes(one, empty) or b"")
    assert gone["removedTopics"] == ["/a"] and gone["removedServices"] == ["/s"]
    assert gone["publishedTopics"] == []


def test_assets_only_from_the_allow_list(tmp_path: Path) -> None:
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "hull.stl").write_bytes(b"solid")
    (meshes / "notes.txt").write_text("x")
    (tmp_path / "secret.stl").write_text("x")
    (meshes / "link.stl").symlink_to(tmp_path / "secret.stl")
    assets = AssetDirectory([meshes])
    assert assets.resolve("package://meshes/hull.stl") == (meshes / "hull.stl").resolve()
    for uri in (
        "file:///etc/passwd",
        "package://meshes/../secret.stl",
        "package://meshes/%2e%2e/secret.stl",
        "package://meshes/link.stl",
        "package://meshes/notes.txt",
        "package://other/hull.stl",
        "package://meshes/missing.stl",
    ):
        assert isinstance(assets.resolve(uri), str), uri
    answer = assets.answer(
        wire.FetchAsset(op="fetchAsset", uri="package://meshes/hull.stl", requestId=9)
    )
    assert answer == wire.fetch_asset_response(9, b"solid")
