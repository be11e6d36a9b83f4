"""A plain eclipse-zenoh program that talks like an rmw_zenoh node (no riverbridge code here).

Written from rmw_zenoh's docs/design.md: data on `<domain>/<name>/<dds type>/<type hash>`,
CDR payloads (rosbags encodes and decodes them), the attachment serialised with zenoh-ext's
serializer (int64 sequence number, int64 source timestamp, 16-byte GID), liveliness tokens
`@ros2_lv/<domain>/<zid>/<nid>/<id>/<kind>/<enclave>/<namespace>/<node>[/<name>/<type>/
<hash>/<qos>]`. It connects to ENDPOINT only (multicast scouting off) and prints one JSON line.

usage:
  python3 zenoh_peer.py ENDPOINT DOMAIN tokens NODE_PREFIX TIMEOUT_S
      wait for a node token whose node name starts with NODE_PREFIX; print every token.
  python3 zenoh_peer.py ENDPOINT DOMAIN imu COUNT TIMEOUT_S
      take COUNT sensor_msgs/msg/Imu samples from /imu/data; print them decoded.
  python3 zenoh_peer.py ENDPOINT DOMAIN wrench SECONDS FORCE_X
      publish geometry_msgs/msg/Wrench (surge force FORCE_X) on /cmd_wrench at 10 Hz.
  python3 zenoh_peer.py ENDPOINT DOMAIN call SERVICE TIMEOUT_S
      find SERVICE's server token, call it (std_srvs/srv/SetBool, data: true) on the key it
      announces, print the response.
  python3 zenoh_peer.py ENDPOINT DOMAIN take TOPIC COUNT TIMEOUT_S [TYPE]
      take COUNT samples of TYPE (std_msgs/msg/String unless told; any type whose `data` is a
      string or bytes) from TOPIC; print their data (bytes: the first 8 in hex) and sizes.
  python3 zenoh_peer.py ENDPOINT DOMAIN latched TOPIC TIMEOUT_S
      join late: ask the publication caches of TOPIC (std_msgs/msg/String, transient local)
      for their history as rmw_zenoh's transient-local subscriptions do; print the first.
  python3 zenoh_peer.py ENDPOINT DOMAIN serve SERVICE SECONDS
      provide std_srvs/srv/SetBool SERVICE (a queryable and its SS token) for SECONDS,
      answering success = data, message "zenoh says <data>"; print the requests it served.
  python3 zenoh_peer.py ENDPOINT DOMAIN bad TOPIC
      publish std_msgs/msg/String on TOPIC three ways wrong (attachment of 20 bytes, a key
      naming a type nobody knows, a payload cut short) and then once right ("good").
"""

import json
import os
import sys
import time

import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from zenoh.ext import Int64, z_deserialize, z_serialize

STORE = get_typestore(Stores.ROS2_JAZZY)
# rosbags holds no service types: std_srvs/srv/SetBool's two halves, from its .srv file.
for _name, _text in (("Request", "bool data"), ("Response", "bool success\nstring message")):
    ((_, _fields),) = get_types_from_msg(_text, "x/msg/X").values()
    STORE.register({f"std_srvs/srv/SetBool_{_name}": ([], _fields)})
ZID_GID = os.urandom(16)


def open_session(endpoint):
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    return zenoh.open(config)


def dds_type(ros_type):
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def type_hash(ros_type):
    """RIHS01 from Jazzy on; Humble's rmw_zenoh writes TypeHashNotSupported instead."""
    if os.environ.get("ROS_DISTRO") == "humble":
        return "TypeHashNotSupported"
    return STORE.hash_rihs01(ros_type)


def attachment(sequence):
    return z_serialize((Int64(sequence), Int64(time.time_ns()), ZID_GID))


def declare_node(session, domain, node):
    zid = str(session.zid())
    token = session.liveliness().declare_token(f"@ros2_lv/{domain}/{zid}/0/0/NN/%/%/{node}")
    return zid, [token]


def declare_endpoint(session, domain, node, kind, entity_id, name, ros_type, hash_):
    zid = str(session.zid())
    mangled = name.replace("/", "%")
    key = (
        f"@ros2_lv/{domain}/{zid}/0/{entity_id}/{kind}/%/%/{node}/{mangled}/"
        f"{dds_type(ros_type)}/{hash_}/::,10:,:,:,,"
    )
    return session.liveliness().declare_token(key)


def tokens(session, domain, prefix, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        keys = [str(r.ok.key_expr) for r in session.liveliness().get(f"@ros2_lv/{domain}/**")]
        nodes = [k.split("/")[8] for k in keys if k.split("/")[5] == "NN"]
        if any(n.startswith(prefix) for n in nodes):
            return {"tokens": sorted(keys)}
        time.sleep(0.1)
    return {"tokens": [], "timeout": True}


def subscribed_samples(session, domain, node, topic, ros_type, count, timeout_s):
    """Up to COUNT samples of TOPIC taken in TIMEOUT_S, as node NODE with a subscription token."""
    _, held = declare_node(session, domain, node)
    hash_ = type_hash(ros_type)
    held.append(declare_endpoint(session, domain, node, "MS", 1, topic, ros_type, hash_))
    key = f"{domain}/{topic.strip('/')}/{dds_type(ros_type)}/{hash_}"
    samples = []
    with session.declare_subscriber(key) as subscriber:
        deadline = time.monotonic() + timeout_s
        while len(samples) < count and time.monotonic() < deadline:
            sample = subscriber.try_recv()
            if sample is None:
                time.sleep(0.01)
                continue
            samples.append(sample)
    return samples


def imu(session, domain, count, timeout_s):
    messages = []
    ros_type = "sensor_msgs/msg/Imu"
    for sample in subscribed_samples(
        session, domain, "imu_listener", "/imu/data", ros_type, count, timeout_s
    ):
        msg = STORE.deserialize_cdr(sample.payload.to_bytes(), ros_type)
        sequence, stamp_ns, gid = z_deserialize(tuple[Int64, Int64, bytes], sample.attachment)
        messages.append(
            {
                "key": str(sample.key_expr),
                "frame_id": msg.header.frame_id,
                "stamp_ns": msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec,
                "accel_z": msg.linear_acceleration.z,
                "covariance_length": len(msg.orientation_covariance),
                "sequence": int(sequence),
                "source_timestamp_ns": int(stamp_ns),
                "gid_length": len(gid),
            }
        )
    return {"messages": messages}


def wrench(session, domain, seconds, force_x):
    ros_type = "geometry_msgs/msg/Wrench"
    _, held = declare_node(session, domain, "zenoh_helm")
    held.append(
        declare_endpoint(
            session, domain, "zenoh_helm", "MP", 1, "/cmd_wrench", ros_type, type_hash(ros_type)
        )
    )
    Wrench = STORE.types[ros_type]
    Vector3 = STORE.types["geometry_msgs/msg/Vector3"]
    key = f"{domain}/cmd_wrench/{dds_type(ros_type)}/{type_hash(ros_type)}"
    publisher = session.declare_publisher(key)
    sent, deadline = 0, time.monotonic() + seconds
    while time.monotonic() < deadline:
        sent += 1  # force.y numbers the commands, so a copy would show
        force = Vector3(x=force_x, y=float(sent), z=0.0)
        command = Wrench(force=force, torque=Vector3(x=0.0, y=0.0, z=0.0))
        payload = bytes(STORE.serialize_cdr(command, ros_type))
        publisher.put(payload, attachment=attachment(sent))
        time.sleep(0.1)
    return {"sent": sent}


def call(session, domain, service, timeout_s):
    mangled = service.replace("/", "%")
    deadline = time.monotonic() + timeout_s
    server = None
    while server is None and time.monotonic() < deadline:
        for reply in session.liveliness().get(f"@ros2_lv/{domain}/**"):
            parts = str(reply.ok.key_expr).split("/")
            if parts[5] == "SS" and parts[9] == mangled:
                server = parts
        time.sleep(0.1)
    if server is None:
        return {"error": "no server token"}
    type_dds, hash_ = server[10], server[11]
    _, held = declare_node(session, domain, "zenoh_caller")
    held.append(
        declare_endpoint(
            session, domain, "zenoh_caller", "SC", 1, service, "std_srvs/srv/SetBool", hash_
        )
    )
    Request = STORE.types["std_srvs/srv/SetBool_Request"]
    payload = bytes(STORE.serialize_cdr(Request(data=True), "std_srvs/srv/SetBool_Request"))
    key = f"{domain}/{service.strip('/')}/{type_dds}/{hash_}"
    replies = list(session.get(key, payload=payload, attachment=attachment(7), timeout=20.0))
    for reply in replies:
        if reply.ok is not None:
            response = STORE.deserialize_cdr(
                reply.ok.payload.to_bytes(), "std_srvs/srv/SetBool_Response"
            )
            sequence, _, gid = z_deserialize(tuple[Int64, Int64, bytes], reply.ok.attachment)
            return {
                "success": response.success,
                "message": response.message,
                "sequence": int(sequence),
                "gid_echoed": gid == ZID_GID,
                "key": key,
            }
    return {"error": "no reply", "replies": len(replies)}


def take(session, domain, topic, count, timeout_s, ros_type="std_msgs/msg/String"):
    data, sizes = [], []
    for sample in subscribed_samples(
        session, domain, "zenoh_reader", topic, ros_type, count, timeout_s
    ):
        msg = STORE.deserialize_cdr(sample.payload.to_bytes(), ros_type)
        data.append(msg.data if isinstance(msg.data, str) else bytes(msg.data).hex()[:16])
        sizes.append(len(msg.data))
    return {"data": data, "sizes": sizes}


def latched(session, domain, topic, timeout_s):
    from zenoh.ext import HistoryConfig, declare_advanced_subscriber

    ros_type = "std_msgs/msg/String"
    key = f"{domain}/{topic.strip('/')}/{dds_type(ros_type)}/{type_hash(ros_type)}"
    history = HistoryConfig(detect_late_publishers=True)
    with declare_advanced_subscriber(session, key, history=history) as subscriber:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            sample = subscriber.try_recv()
            if sample is not None:
                return {"data": STORE.deserialize_cdr(sample.payload.to_bytes(), ros_type).data}
            time.sleep(0.01)
    return {"data": None}


def serve(session, domain, service, seconds):
    ros_type = "std_srvs/srv/SetBool"
    # rosbags cannot hash a service type; a client takes the key from the server's token, so
    # any hash works as long as the token and the queryable agree.
    humble = os.environ.get("ROS_DISTRO") == "humble"
    hash_ = "TypeHashNotSupported" if humble else "RIHS01_" + "5" * 64
    _, held = declare_node(session, domain, "zenoh_gatekeeper")
    held.append(
        declare_endpoint(session, domain, "zenoh_gatekeeper", "SS", 1, service, ros_type, hash_)
    )
    served = []

    def answer(query):
        request = STORE.deserialize_cdr(query.payload.to_bytes(), "std_srvs/srv/SetBool_Request")
        sequence, _, gid = z_deserialize(tuple[Int64, Int64, bytes], query.attachment)
        served.append({"data": request.data, "sequence": int(sequence), "gid_length": len(gid)})
        Response = STORE.types["std_srvs/srv/SetBool_Response"]
        response = Response(success=request.data, message=f"zenoh says {request.data}")
        payload = bytes(STORE.serialize_cdr(response, "std_srvs/srv/SetBool_Response"))
        reply = z_serialize((Int64(int(sequence)), Int64(time.time_ns()), bytes(gid)))
        query.reply(query.key_expr, payload, attachment=reply)

    key = f"{domain}/{service.strip('/')}/{dds_type(ros_type)}/{hash_}"
    with session.declare_queryable(key, answer, complete=True):  # as rmw_zenoh declares them
        time.sleep(seconds)
    return {"served": served}


def bad(session, domain, topic):
    ros_type = "std_msgs/msg/String"
    mangled = topic.replace("/", "%")
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:  # the bridge's subscription must be there first
        keys = [
            str(r.ok.key_expr).split("/") for r in session.liveliness().get(f"@ros2_lv/{domain}/**")
        ]
        if any(k[5] == "MS" and k[9] == mangled for k in keys):
            break
        time.sleep(0.1)
    String = STORE.types[ros_type]
    good = bytes(STORE.serialize_cdr(String(data="good"), ros_type))
    key = f"{domain}/{topic.strip('/')}/{dds_type(ros_type)}/{type_hash(ros_type)}"
    session.put(key, good, attachment=b"\x00" * 20)
    session.put(
        f"{domain}/{topic.strip('/')}/nobody::msg::dds_::Knows_/RIHS01_00",
        good,
        attachment=attachment(2),
    )
    session.put(key, good[:6], attachment=attachment(3))
    session.put(key, good, attachment=attachment(4))
    return {"sent": 4}


def main(argv):
    endpoint, domain, command, *args = argv
    session = open_session(endpoint)
    try:
        if command == "tokens":
            result = tokens(session, domain, args[0], float(args[1]))
        elif command == "imu":
            result = imu(session, domain, int(args[0]), float(args[1]))
        elif command == "wrench":
            result = wrench(session, domain, float(args[0]), float(args[1]))
        elif command == "latched":
            result = latched(session, domain, args[0], float(args[1]))
        elif command == "serve":
            result = serve(session, domain, args[0], float(args[1]))
        elif command == "take":
            result = take(session, domain, args[0], int(args[1]), float(args[2]), *args[3:])
        elif command == "call":
            result = call(session, domain, args[0], float(args[1]))
        else:
            result = bad(session, domain, args[0])
        print(json.dumps(result), flush=True)
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
