"""The pure codecs of bridge.zenoh against rmw_zenoh's documented examples (design.md)."""

from __future__ import annotations

import pytest

from bridge.dds.qos import QosProfile
from bridge.zenoh.attachment import (
    ATTACHMENT_BYTES,
    Attachment,
    AttachmentProblem,
    decode_attachment,
    encode_attachment,
    entity_gid,
)
from bridge.zenoh.graph import ZenohGraph
from bridge.zenoh.keys import (
    TYPE_HASH_UNSUPPORTED,
    KeyProblem,
    data_key,
    parse_data_key,
    type_hash,
)
from bridge.zenoh.liveliness import (
    Endpoint,
    Entity,
    EntityKind,
    TokenProblem,
    parse_qos_element,
    parse_token,
    qos_element,
    token_key,
)

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
# design.md's examples, verbatim.
NODE_TOKEN = "@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
PUB_TOKEN = (
    "@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/"
    f"std_msgs::msg::dds_::String_/{STRING_HASH}/::,7:,:,:,,"
)


def test_data_keys_follow_rmw_zenoh():
    key = data_key(0, "/chatter", "std_msgs/msg/String", STRING_HASH)
    assert key == f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    assert parse_data_key(key).name == "/chatter"
    parsed = parse_data_key("3/robot1/cmd/std_srvs::srv::dds_::SetBool_/TypeHashNotSupported")
    assert (parsed.domain, parsed.name, parsed.type_name) == (
        3,
        "/robot1/cmd",
        "std_srvs/srv/SetBool",
    )
    for bad in ("0/chatter/String/x", "x/chatter/std_msgs::msg::dds_::String_/h", "0/a"):
        with pytest.raises(KeyProblem):
            parse_data_key(bad)
    with pytest.raises(KeyProblem):
        data_key(0, "/a/*", "std_msgs/msg/String", STRING_HASH)


def test_type_hash_per_distro(registry):
    assert type_hash(registry, "std_msgs/msg/String", "jazzy") == STRING_HASH
    assert type_hash(registry, "std_msgs/msg/String", "humble") == TYPE_HASH_UNSUPPORTED
    assert type_hash(registry, "std_srvs/srv/SetBool", "jazzy") == TYPE_HASH_UNSUPPORTED


def test_tokens_round_trip_design_md_examples():
    node = parse_token(NODE_TOKEN)
    assert node.kind is EntityKind.NODE and node.node == "/listener" and node.endpoint is None
    assert token_key(node) == NODE_TOKEN
    pub = parse_token(PUB_TOKEN)
    assert pub.kind is EntityKind.PUBLISHER and pub.entity_id == 10 and pub.node == "/talker"
    assert pub.endpoint == Endpoint(
        "/chatter", "std_msgs/msg/String", STRING_HASH, QosProfile(depth=7)
    )
    assert token_key(pub) == PUB_TOKEN


def test_namespaced_service_token():
    entity = Entity(
        5,
        "ab12",
        0,
        3,
        EntityKind.SERVICE,
        "/vessel",
        "bridge",
        endpoint=Endpoint("/vessel/lock", "std_srvs/srv/SetBool", TYPE_HASH_UNSUPPORTED),
    )
    key = token_key(entity)
    assert key == (
        "@ros2_lv/5/ab12/0/3/SS/%/%vessel/bridge/%vessel%lock/std_srvs::srv::dds_::SetBool_/"
        "TypeHashNotSupported/::,:,:,:,,"
    )
    assert parse_token(key) == entity


@pytest.mark.parametrize(
    ("qos", "element"),
    [
        (QosProfile(depth=42), "::,:,:,:,,"),
        (QosProfile(depth=10), "::,10:,:,:,,"),
        (QosProfile(reliable=False, depth=5), "2::,5:,:,:,,"),
        (QosProfile(transient_local=True, depth=1), ":1:,1:,:,:,,"),
        (QosProfile(depth=0), "::2,:,:,:,,"),
    ],
)
def test_qos_element(qos, element):
    assert qos_element(qos) == element
    assert parse_qos_element(element) == qos


@pytest.mark.parametrize(
    "bad",
    [
        "@ros2_lv/0/z/0/0/XX/%/%/n",
        "@ros2_lv/0/z/0/0/NN/%/%",
        "@ros2_lv/0/z/0/0/MP/%/%/n",
        "@ros2_lv/x/z/0/0/NN/%/%/n",
        "@other/0/z/0/0/NN/%/%/n",
        PUB_TOKEN.replace("::,7:,:,:,,", "bad"),
        PUB_TOKEN.replace("std_msgs::msg::dds_::String_", "String"),
    ],
)
def test_bad_tokens_are_refused(bad):
    with pytest.raises(TokenProblem):
        parse_token(bad)


def test_attachment_is_33_bytes_of_zenoh_ext_serialisation():
    gid = entity_gid(PUB_TOKEN)
    data = encode_attachment(Attachment(5, 7, gid))
    assert len(data) == ATTACHMENT_BYTES == 33
    assert data[:17] == bytes.fromhex("0500000000000000070000000000000010")
    assert decode_attachment(data) == Attachment(5, 7, gid)
    for bad in (None, data[:-1], data + b"\0", data[:16] + b"\x0f" + data[17:]):
        with pytest.raises(AttachmentProblem):
            decode_attachment(bad)


def test_graph_from_tokens_leaves_out_its_own_session():
    graph = ZenohGraph(0, own_zid="aac3178e146ba6f1fc6e6a4085e77f21")
    assert graph.put(NODE_TOKEN) is None  # our own
    assert graph.put(PUB_TOKEN) is not None
    sub = (
        PUB_TOKEN.replace("/MP/", "/MS/").replace("talker", "listener").replace("/0/10/", "/0/11/")
    )
    graph.put(sub)
    topics = graph.topics()
    assert topics["/chatter"].publishers == {"/talker": [QosProfile(depth=7)]}
    assert topics["/chatter"].subscribers == {"/listener"}
    assert graph.nodes() == {"/talker", "/listener"}
    assert graph.delete(PUB_TOKEN) and "/talker" not in graph.topics()["/chatter"].publishers
    assert graph.put(PUB_TOKEN.replace("@ros2_lv/0/", "@ros2_lv/1/")) is None  # another domain
