"""Topic ops in the sans-I/O core: delivery, combined settings, latching, throttle, clean-up."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bridge.outgoing import MIN_FRAGMENT_SIZE
from schemas.codec_cdr import from_cdr
from tests.bridge.bridge_harness import CoreHarness


def advertise(
    h: CoreHarness,
    client: int,
    topic: str = "/chatter",
    type_name: str = "std_msgs/String",
    **extra,
) -> None:
    h.send(client, {"op": "advertise", "topic": topic, "type": type_name, **extra})


def publish(h: CoreHarness, client: int, msg: dict, topic: str = "/chatter", **extra) -> None:
    h.send(client, {"op": "publish", "topic": topic, "msg": msg, **extra})


def test_publish_reaches_subscriber_with_its_topic_spelling(harness):
    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "chatter", "type": "std_msgs/msg/String"})
    advertise(harness, pub)
    publish(harness, pub, {"data": "hello"})
    assert harness.outbox(sub) == [{"op": "publish", "topic": "chatter", "msg": {"data": "hello"}}]
    assert harness.outbox(pub) == []


def test_one_delivery_per_connection_however_many_ids(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    for sub_id in ("a", "b", "c"):
        harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": sub_id})
    publish(harness, pub, {"data": "x"})
    assert len(harness.outbox(sub)) == 1
    harness.send(sub, {"op": "unsubscribe", "topic": "/chatter", "id": "a"})
    publish(harness, pub, {"data": "y"})
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["y"]
    harness.send(sub, {"op": "unsubscribe", "topic": "/chatter"})
    publish(harness, pub, {"data": "z"})
    assert harness.outbox(sub) == []


def test_strongest_compression_wins_and_unknown_means_json(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": 1, "compression": "zip"})
    publish(harness, pub, {"data": "plain"})
    assert harness.frames(sub)[0].text
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": 2, "compression": "png"})
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": 3, "compression": "cbor"})
    publish(harness, pub, {"data": "binary"})
    frames = harness.frames(sub)
    assert len(frames) == 1 and not frames[0].text
    harness.send(sub, {"op": "unsubscribe", "topic": "/chatter", "id": 3})
    publish(harness, pub, {"data": "png"})
    assert harness.outbox(sub)[0]["op"] == "png"


def test_publisher_that_subscribes_receives_its_own_message(harness):
    client = harness.connect()
    advertise(harness, client)
    harness.send(client, {"op": "subscribe", "topic": "/chatter"})
    publish(harness, client, {"data": "echo"})
    assert harness.outbox(client)[0]["msg"] == {"data": "echo"}


def test_waiting_subscription_gives_the_type_to_publish(harness):
    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/later", "type": "std_msgs/Int32"})
    publish(harness, pub, {"data": 7}, topic="/later")
    assert harness.outbox(sub)[0]["msg"] == {"data": 7}
    assert harness.state.graph.topics["/later"].publishers.keys() == {"/rosbridge_client_1"}


def test_publish_to_unknown_topic_is_dropped_silently(harness):
    pub = harness.connect()
    publish(harness, pub, {"data": "lost"}, topic="/nowhere")
    assert harness.outbox(pub) == []
    assert "/nowhere" not in harness.state.graph.topics


def test_missing_fields_take_defaults_and_bad_fields_drop_the_message(harness):
    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/pose", "type": "geometry_msgs/Pose"})
    publish(harness, pub, {"position": {"x": 1}}, topic="/pose")
    publish(harness, pub, {"position": {"x": "far"}}, topic="/pose")
    publish(harness, pub, {"no_such_field": 1}, topic="/pose")
    received = harness.outbox(sub)
    assert len(received) == 1
    assert received[0]["msg"]["position"] == {"x": 1.0, "y": 0.0, "z": 0.0}
    assert set(received[0]["msg"]["orientation"]) == {"x", "y", "z", "w"}


def test_type_conflict_is_refused(harness):
    first, second = harness.connect(), harness.connect()
    advertise(harness, first)
    advertise(harness, second, type_name="std_msgs/Int32")
    entry = harness.state.graph.topics["/chatter"]
    assert entry.type_name == "std_msgs/msg/String"
    assert "/rosbridge_client_2" not in entry.publishers


def test_latched_message_reaches_each_late_subscriber_once(harness):
    pub = harness.connect()
    advertise(harness, pub, latch=True)
    publish(harness, pub, {"data": "old"})
    publish(harness, pub, {"data": "latest"})
    for _ in range(3):
        late = harness.connect()
        harness.send(late, {"op": "subscribe", "topic": "/chatter", "id": 1})
        harness.send(late, {"op": "subscribe", "topic": "/chatter", "id": 2})
        assert [m["msg"]["data"] for m in harness.outbox(late)] == ["latest"]


def test_unlatched_topic_gives_late_subscribers_nothing(harness):
    pub = harness.connect()
    advertise(harness, pub)
    publish(harness, pub, {"data": "gone"})
    late = harness.connect()
    harness.send(late, {"op": "subscribe", "topic": "/chatter"})
    assert harness.outbox(late) == []


def test_throttle_without_queue_drops_inside_the_window(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "throttle_rate": 100})
    for i in range(5):
        publish(harness, pub, {"data": str(i)})
        harness.advance(0.03)
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["0", "4"]


def test_throttle_with_queue_keeps_the_newest_and_releases_on_time(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(
        sub, {"op": "subscribe", "topic": "/chatter", "throttle_rate": 100, "queue_length": 2}
    )
    for i in range(5):
        publish(harness, pub, {"data": str(i)})
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["0"]
    harness.advance(0.1)
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["3"]
    harness.advance(0.1)
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["4"]
    harness.advance(1.0)
    assert harness.outbox(sub) == []


def test_queue_flushes_newest_when_throttle_is_lifted(harness):
    """rosbridge's test: throttle 10 s, queue 10, 1000 messages -> first, then 990..999."""
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(
        sub,
        {
            "op": "subscribe",
            "topic": "/chatter",
            "id": "q",
            "throttle_rate": 10_000,
            "queue_length": 10,
        },
    )
    for i in range(1000):
        publish(harness, pub, {"data": str(i)})
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["0"]
    harness.send(
        sub,
        {"op": "subscribe", "topic": "/chatter", "id": "q", "throttle_rate": 0, "queue_length": 10},
    )
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == [str(i) for i in range(990, 1000)]


def test_min_throttle_over_ids(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": 1, "throttle_rate": 1000})
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "id": 2, "throttle_rate": 0})
    publish(harness, pub, {"data": "a"})
    publish(harness, pub, {"data": "b"})
    assert len(harness.outbox(sub)) == 2


def test_cbor_and_cbor_raw_frames(harness, registry):
    pub, sub, raw = harness.connect(), harness.connect(), harness.connect()
    advertise(harness, pub, topic="/imu", type_name="sensor_msgs/msg/Imu")
    harness.send(sub, {"op": "subscribe", "topic": "/imu", "compression": "cbor"})
    harness.send(raw, {"op": "subscribe", "topic": "/imu", "compression": "cbor-raw"})
    covariance = [float(i) for i in range(9)]
    publish(
        harness,
        pub,
        {
            "header": {"frame_id": "imu", "stamp": {"sec": 5, "nanosec": 6}},
            "angular_velocity_covariance": covariance,
        },
        topic="/imu",
    )
    decoded = harness.outbox(sub)[0]["msg"]
    assert decoded["header"] == {"stamp": {"sec": 5, "nanosec": 6}, "frame_id": "imu"}
    assert decoded["angular_velocity_covariance"] == covariance
    envelope = harness.outbox(raw)[0]["msg"]
    assert envelope["secs"] * 10**9 + envelope["nsecs"] == harness.now_ns
    roundtrip = from_cdr(registry, "sensor_msgs/msg/Imu", envelope["bytes"])
    assert roundtrip["header"]["frame_id"] == "imu"


def test_encoded_once_and_shared_by_all_subscribers(harness):
    pub = harness.connect()
    subs = [harness.connect() for _ in range(3)]
    advertise(harness, pub, topic="/cloud", type_name="sensor_msgs/PointCloud2")
    for sub in subs:
        harness.send(sub, {"op": "subscribe", "topic": "/cloud", "compression": "cbor"})
    publish(harness, pub, {"data": list(range(256)) * 4}, topic="/cloud")
    frames = [harness.frames(sub)[0] for sub in subs]
    assert all(f.data is frames[0].data for f in frames)


def test_numeric_sequences_arrive_as_typed_arrays_in_cbor(harness):
    pub, sub = harness.connect(), harness.connect()
    harness.send(
        sub,
        {
            "op": "subscribe",
            "topic": "/arr",
            "type": "std_msgs/Float32MultiArray",
            "compression": "cbor",
        },
    )
    publish(harness, pub, {"data": [1.5, 2.5, 3.5]}, topic="/arr")
    data = harness.outbox(sub)[0]["msg"]["data"]
    assert isinstance(data, np.ndarray) and data.dtype == np.float32
    assert data.tolist() == [1.5, 2.5, 3.5]


def test_large_text_frames_are_fragmented_with_integer_totals(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "fragment_size": 1000})
    publish(harness, pub, {"data": "x" * 2500})
    fragments = harness.outbox(sub)
    assert {f["op"] for f in fragments} == {"fragment"} and len(fragments) == 3
    assert all(isinstance(f["total"], int) and f["total"] == len(fragments) for f in fragments)
    text = "".join(f["data"] for f in sorted(fragments, key=lambda f: f["num"]))
    assert text == '{"op":"publish","topic":"/chatter","msg":{"data":"' + "x" * 2500 + '"}}'


def test_fragment_sizes_below_the_floor_are_raised_to_it(harness):
    """fragment_size 1 would send one frame per character, each repeating envelope and id."""
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "fragment_size": 1})
    publish(harness, pub, {"data": "x" * 2500})
    fragments = harness.outbox(sub)
    assert len(fragments) == 3  # 2,553 characters of JSON
    assert all(len(f["data"]) <= MIN_FRAGMENT_SIZE for f in fragments)


def test_huge_fragment_size_means_no_fragmentation(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "fragment_size": 2147483647})
    publish(harness, pub, {"data": "x" * 1000})
    assert harness.outbox(sub)[0]["op"] == "publish"


def test_json_in_binary_frames_is_accepted(harness):
    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "type": "std_msgs/String"})
    harness.send(pub, b'{"topic":"/chatter","msg":{"data":"ros#"},"op":"publish","id":null}')
    assert harness.outbox(sub)[0]["msg"]["data"] == "ros#"


def test_cbor_publish_from_clients(harness):
    from schemas import codec_cbor

    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/chatter", "type": "std_msgs/String"})
    harness.send(
        pub, codec_cbor.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": "cbor"}})
    )
    assert harness.outbox(sub)[0]["msg"]["data"] == "cbor"


def test_disconnect_releases_subscriptions_and_publishers(harness):
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub, latch=True)
    harness.send(sub, {"op": "subscribe", "topic": "/chatter"})
    publish(harness, pub, {"data": "x"})
    harness.disconnect(pub)
    entry = harness.state.graph.topics["/chatter"]
    assert entry.publishers == {} and entry.latched is None
    harness.disconnect(sub)
    assert "/chatter" not in harness.state.graph.topics
    assert harness.state.topic_subscriptions == {}
    assert harness.state.sessions == {}


def test_unadvertise_by_id_keeps_other_ids(harness):
    pub = harness.connect()
    advertise(harness, pub, id="a")
    advertise(harness, pub, id="b")
    harness.send(pub, {"op": "unadvertise", "topic": "/chatter", "id": "a"})
    assert "/chatter" in harness.state.graph.topics
    harness.send(pub, {"op": "unadvertise", "topic": "/chatter", "id": "b"})
    assert "/chatter" not in harness.state.graph.topics


def test_a_large_publish_is_checked_off_the_loop_and_refused_there_too(harness):
    import base64
    import json

    from bridge.inbound import read_frame
    from bridge.validation import InvalidMessage, ValidMessage

    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/img", "type": "sensor_msgs/Image"})
    pixels = bytes(range(256)) * 16
    encoded = base64.b64encode(pixels).decode()
    frame = json.dumps({"op": "publish", "topic": "/img", "msg": {"data": encoded, "width": 64}})
    work = harness.core.offload(read_frame(frame, harness.now_ns), harness.now_ns)
    assert work is not None, "5 kB of base64 is worth a worker"
    checked = work.run()
    assert isinstance(checked, ValidMessage) and checked.msg["data"] == pixels
    harness.receive_offloaded(pub, frame)
    delivered = harness.outbox(sub)
    assert len(delivered) == 1
    assert base64.b64decode(delivered[0]["msg"]["data"]) == pixels
    assert delivered[0]["msg"]["width"] == 64
    bad = json.dumps({"op": "publish", "topic": "/img", "msg": {"data": encoded, "width": "x"}})
    work = harness.core.offload(read_frame(bad, harness.now_ns), harness.now_ns)
    assert work is not None and isinstance(work.run(), InvalidMessage)
    harness.receive_offloaded(pub, bad)
    assert harness.outbox(sub) == []
    small = json.dumps({"op": "publish", "topic": "/img", "msg": {"width": 1}})
    assert harness.core.offload(read_frame(small, harness.now_ns), harness.now_ns) is None


def test_a_publish_checked_off_the_loop_is_not_checked_again_and_keeps_its_sizes(registry):
    import json

    from bridge.inbound import read_frame
    from bridge.validation import ValidMessage
    from schemas.codec_cdr import cdr_size

    harness = CoreHarness(registry, offload_threshold_bytes=1)
    pub = harness.connect()
    advertise(harness, pub, topic="/fix", type_name="sensor_msgs/NavSatFix", latch=True)
    frame = read_frame(
        json.dumps(
            {
                "op": "publish",
                "topic": "/fix",
                "latch": True,
                "msg": {
                    "header": {"stamp": {"sec": 3, "nanosec": 4}, "frame_id": "gnss"},
                    "latitude": 51.6,
                },
            }
        ),
        harness.now_ns,
    )
    work = harness.core.offload(frame, harness.now_ns)
    assert work is not None and work.spec is registry.message("sensor_msgs/msg/NavSatFix")
    checked = work.run()
    assert isinstance(checked, ValidMessage)
    assert checked.size_hint >= frame.wire_bytes
    assert checked.cdr_bytes == cdr_size(registry, "sensor_msgs/msg/NavSatFix", checked.msg)
    harness._record(
        harness.core.receive_frame(pub, replace(frame, checked=checked), harness.now_ns)
    )
    latched = harness.state.graph.topics["/fix"].latched
    assert latched.msg is checked.msg, "the worker's message is the one published"
    assert (latched.size_hint, latched.cdr_bytes) == (checked.size_hint, checked.cdr_bytes)


def test_a_publish_checked_off_the_loop_is_checked_again_when_the_topic_changed_type(registry):
    import json

    from bridge.inbound import read_frame

    harness = CoreHarness(registry, offload_threshold_bytes=1)
    pub, sub = harness.connect(), harness.connect()
    advertise(harness, pub, topic="/t", type_name="std_msgs/String")
    frame = read_frame(
        json.dumps({"op": "publish", "topic": "/t", "msg": {"data": "hello"}}), harness.now_ns
    )
    work = harness.core.offload(frame, harness.now_ns)
    assert work is not None
    checked = work.run()
    harness.send(pub, {"op": "unadvertise", "topic": "/t"})
    advertise(harness, pub, topic="/t", type_name="std_msgs/Int32")
    harness.send(sub, {"op": "subscribe", "topic": "/t"})
    harness._record(
        harness.core.receive_frame(pub, replace(frame, checked=checked), harness.now_ns)
    )
    assert harness.outbox(sub) == [], "a String is no Int32"
    publish(harness, pub, {"data": 7}, topic="/t")
    assert [m["msg"] for m in harness.outbox(sub)] == [{"data": 7}]


def test_topic_glob_gates_advertise_publish_and_subscribe(registry):
    harness = CoreHarness(registry, topics_glob=("/cam/*",))
    client = harness.connect()
    advertise(harness, client, topic="/secret")
    harness.send(client, {"op": "subscribe", "topic": "/secret", "type": "std_msgs/String"})
    advertise(harness, client, topic="/cam/front")
    assert set(harness.state.graph.topics) == {"/rosout", "/cam/front"}


def test_fragment_size_in_any_message_applies_to_the_whole_client(harness):
    client = harness.connect()
    harness.send(
        client,
        {
            "op": "call_service",
            "service": "/rosapi/message_details",
            "args": {"type": "sensor_msgs/msg/Imu"},
            "fragment_size": 1000,
            "id": "v",
        },
    )
    fragments = harness.outbox(client)
    assert len(fragments) > 1 and {f["id"] for f in fragments} == {"v"}
    harness.send(client, {"op": "set_level", "level": "none", "fragment_size": None})
    harness.send(
        client,
        {
            "op": "call_service",
            "service": "/rosapi/message_details",
            "args": {"type": "sensor_msgs/msg/Imu"},
        },
    )
    assert harness.outbox(client)[0]["op"] == "service_response"


class RecordingSink:
    def __init__(self) -> None:
        self.seen: list[tuple[str, str]] = []

    def accept(self, ctx, message, origin_node) -> None:
        self.seen.append((message.topic, origin_node))


def test_external_sinks_and_sources_share_the_graph(harness):
    sink = RecordingSink()
    harness.core.add_sink(sink)
    pub, sub = harness.connect(), harness.connect()
    harness.send(sub, {"op": "subscribe", "topic": "/dds", "type": "std_msgs/String"})
    publish(harness, pub, {"data": "from ws"}, topic="/dds")
    harness._record(
        harness.core.publish_external(
            "/dds_node", "/dds", "std_msgs/String", {"data": "from dds"}, harness.now_ns
        )
    )
    assert [m["msg"]["data"] for m in harness.outbox(sub)] == ["from ws", "from dds"]
    assert sink.seen == [("/dds", "/rosbridge_client_1"), ("/dds", "/dds_node")]
    assert "/dds_node" in harness.state.graph.topics["/dds"].publishers


def test_latched_publish_after_unadvertise_leaves_no_publisher(harness):
    client = harness.connect()
    harness.send(client, {"op": "advertise", "topic": "/l", "type": "std_msgs/String", "id": "adv"})
    harness.send(client, {"op": "publish", "topic": "/l", "msg": {}, "latch": True, "id": "pub:1"})
    harness.send(client, {"op": "unadvertise", "topic": "/l", "id": "adv"})
    assert "/l" not in harness.state.graph.topics
