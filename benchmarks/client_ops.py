"""What building an op costs the client library, next to json-encoding the same plain dict.

For each op :class:`clients.protocol.ClientProtocol` sends: the median µs of the protocol
method that returns the frame (state bookkeeping, model, encoding) and of
``codec_json.dumps`` of a plain dict with the same keys (the floor), and their ratio. Then
``encode_publish`` of an IMU-sized message and of a 4 MB PointCloud2 (345,600 points) in JSON
and CBOR next to ``schemas.frames.publish_*`` of the same message (what the bridge uses).
Then, inbound, ``ClientProtocol.receive`` of each op a server sends (decode, reading into its
`schemas.ops` model, routing) next to ``codec_json.loads`` of the same frame.
Run as ``python -m benchmarks.client_ops``; medians hold up on a loaded machine, ratios more so.

Inbound ops read into their models (house-typed, 2026-11-26; load 6-11, median of three runs
interleaved with the code before, µs): an Imu publish 10.6 -> 12.5 untyped, 38.8 -> 44.1 typed
(``parse_publish`` ~0.75 µs of CPU time against ~0.2 for the two dict reads it replaced; the
rest is noise: the unchanged outbound ops moved 0.91-1.13x in the same runs); control ops
(service_response, action_result, ...) 2-7 -> 10-15, pydantic validating each.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import orjson

from clients.events import GoalRequest, ServiceRequest
from clients.protocol import ClientProtocol
from clients.wire import Frame
from schemas import codec_json, frames
from schemas.message import normalize
from schemas.pointcloud import pack_points
from schemas.registry import TypeRegistry

LIDAR_POINTS = 345_600  # thesis LIDAR: 1440 azimuth x 240 elevation rays
REQUEST = ServiceRequest("call_service:/add:7", "/add", {"a": 1, "b": 2})
GOAL = GoalRequest("send_action_goal:/fib:3", "/fib", "example/action/Fibonacci", {"order": 4})

Setup = Callable[[ClientProtocol], Any]
Build = Callable[[ClientProtocol], Frame | None]


def _subscribed(p: ClientProtocol) -> str:
    return p.subscribe("/imu", "sensor_msgs/msg/Imu")[0]


def _goal(p: ClientProtocol) -> str:
    return p.send_action_goal("/fib", "example/action/Fibonacci")[0]


#: (op, setup run untimed before each call and returning the call's argument, the timed call).
OPS: list[tuple[str, Setup, Callable[[ClientProtocol, Any], Frame | None]]] = [
    (
        "advertise",
        lambda p: p.unadvertise("/chat"),
        lambda p, _: p.advertise("/chat", "std_msgs/msg/String"),
    ),
    (
        "unadvertise",
        lambda p: p.advertise("/chat", "std_msgs/msg/String"),
        lambda p, _: p.unadvertise("/chat"),
    ),
    (
        "subscribe",
        lambda p: [p.unsubscribe(s) for s in list(p.subscriptions)],
        lambda p, _: p.subscribe("/imu", "sensor_msgs/msg/Imu")[1],
    ),
    ("unsubscribe", _subscribed, lambda p, sub_id: p.unsubscribe(sub_id)),
    (
        "call_service",
        lambda p: None,
        lambda p, _: p.call_service("/add", {"a": 1, "b": 2}, timeout_s=2.0)[1],
    ),
    (
        "advertise_service",
        lambda p: None,
        lambda p, _: p.advertise_service("/add", "example/srv/AddTwoInts"),
    ),
    (
        "unadvertise_service",
        lambda p: p.advertise_service("/add", "example/srv/AddTwoInts"),
        lambda p, _: p.unadvertise_service("/add"),
    ),
    (
        "service_response",
        lambda p: None,
        lambda p, _: p.service_response(REQUEST, {"sum": 3}, result=True),
    ),
    (
        "send_action_goal",
        lambda p: None,
        lambda p, _: p.send_action_goal("/fib", "example/action/Fibonacci", {"order": 4})[1],
    ),
    ("cancel_action_goal", _goal, lambda p, goal_id: p.cancel_action_goal(goal_id)),
    (
        "advertise_action",
        lambda p: None,
        lambda p, _: p.advertise_action("/fib", "example/action/Fibonacci"),
    ),
    (
        "unadvertise_action",
        lambda p: p.advertise_action("/fib", "example/action/Fibonacci"),
        lambda p, _: p.unadvertise_action("/fib"),
    ),
    (
        "action_feedback",
        lambda p: None,
        lambda p, _: p.action_feedback(GOAL, {"partial": [0, 1, 1]}),
    ),
    (
        "action_result",
        lambda p: None,
        lambda p, _: p.action_result(GOAL, {"sequence": [0, 1, 1, 2]}, status=4, result=True),
    ),
]


def median_us(
    call: Callable[[], object],
    repeats: int,
    setup: Callable[[], object] | None = None,
) -> float:
    """Median wall time of ``call`` in µs over ``repeats`` calls (``setup`` untimed before each)."""
    times = []
    for _ in range(repeats):
        if setup is not None:
            setup()
        start = time.perf_counter_ns()
        call()
        times.append(time.perf_counter_ns() - start)
    return statistics.median(times) / 1e3


def op_rows(registry: TypeRegistry, repeats: int) -> list[tuple[str, float, float]]:
    """(op, µs of the protocol method, µs of dumps of the plain dict) for each op."""
    rows = []
    for name, setup, build in OPS:
        proto = ClientProtocol(encoding="json", spec_lookup=registry.message)
        state: list[Any] = [None]

        def prepare(
            proto: ClientProtocol = proto, setup: Setup = setup, state: list[Any] = state
        ) -> None:
            state[0] = setup(proto)

        def call(
            proto: ClientProtocol = proto,
            build: Any = build,
            state: list[Any] = state,
        ) -> Frame | None:
            return build(proto, state[0])

        prepare()
        frame = call()
        assert frame is not None, name
        plain = orjson.loads(frame.data)
        assert plain["op"] == name, (name, plain)
        rows.append(
            (
                name,
                median_us(call, repeats, prepare),
                median_us(lambda plain=plain: codec_json.dumps(plain), repeats),
            )
        )
    return rows


def imu_message(registry: TypeRegistry) -> dict[str, Any]:
    """A sensor_msgs/Imu in canonical form (covariances as float64 arrays): ~200 B of JSON."""
    raw = {
        "header": {"stamp": {"sec": 1_700_000_000, "nanosec": 5}, "frame_id": "imu"},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.3826834, "w": 0.9238795},
        "orientation_covariance": np.eye(3).ravel() * 1e-3,
        "angular_velocity": {"x": 0.01, "y": -0.02, "z": 0.1},
        "angular_velocity_covariance": np.eye(3).ravel() * 1e-4,
        "linear_acceleration": {"x": 0.2, "y": 0.0, "z": 9.81},
        "linear_acceleration_covariance": np.eye(3).ravel() * 1e-2,
    }
    return normalize(registry.message("sensor_msgs/msg/Imu"), raw, now_ns=0)


def publish_rows(
    registry: TypeRegistry, points: int, repeats: int, big_repeats: int
) -> list[tuple[str, float, float, int]]:
    """(case, µs of encode_publish, µs of schemas.frames.publish_*, frame bytes)."""
    cloud = normalize(
        registry.message("sensor_msgs/msg/PointCloud2"),
        pack_points(
            np.random.default_rng(0).random((points, 4), dtype=np.float32),
            1_700_000_000 * 10**9,
            "lidar",
        ),
        now_ns=0,
    )
    cases = [
        ("Imu", "/imu", imu_message(registry), repeats),
        (f"PointCloud2 {points} pts", "/lidar", cloud, big_repeats),
    ]
    plain = {"json": frames.publish_json, "cbor": frames.publish_cbor}
    rows = []
    for label, topic, msg, n in cases:
        for encoding in ("json", "cbor"):
            proto = ClientProtocol(encoding=encoding, spec_lookup=registry.message)
            size = len(proto.encode_publish(topic, msg).data)
            rows.append(
                (
                    f"publish {label} {encoding}",
                    median_us(lambda p=proto, t=topic, m=msg: p.encode_publish(t, m), n),
                    median_us(lambda f=plain[encoding], t=topic, m=msg: f(t, m), n),
                    size,
                )
            )
    return rows


def _pending(op: str, make: Callable[[ClientProtocol], str], tail: str) -> Setup:
    """A setup that opens what `op` answers (a call, a goal) and returns the frame to receive."""

    def setup(p: ClientProtocol) -> str:
        return f'{{"op":"{op}","id":"{make(p)}",{tail}}}'

    return setup


def _fixed(frame: str) -> Setup:
    return lambda p: frame


_IMU_JSON = (
    '{"op":"publish","topic":"/imu","msg":{"header":{"stamp":{"sec":1700000000,"nanosec":5},'
    '"frame_id":"imu"},"orientation":{"x":0.0,"y":0.0,"z":0.38,"w":0.92},'
    '"orientation_covariance":[0.001,0,0,0,0.001,0,0,0,0.001],'
    '"angular_velocity":{"x":0.01,"y":-0.02,"z":0.1},'
    '"angular_velocity_covariance":[0.0001,0,0,0,0.0001,0,0,0,0.0001],'
    '"linear_acceleration":{"x":0.2,"y":0.0,"z":9.81},'
    '"linear_acceleration_covariance":[0.01,0,0,0,0.01,0,0,0,0.01]}}'
)

#: (inbound op, setup returning the frame to receive on a prepared protocol).
INBOUND: list[tuple[str, Setup]] = [
    ("publish Imu untyped", _fixed(_IMU_JSON.replace('"/imu"', '"/raw"'))),
    ("publish Imu typed", _fixed(_IMU_JSON)),
    (
        "service_response",
        _pending(
            "service_response",
            lambda p: p.call_service("/add", {"a": 1})[0],
            '"service":"/add","values":{"sum":3},"result":true',
        ),
    ),
    (
        "call_service",
        _fixed(
            '{"op":"call_service","id":"service_request:/add:1","service":"/add",'
            '"args":{"a":1,"b":2}}'
        ),
    ),
    (
        "action_feedback",
        lambda p: (
            f'{{"op":"action_feedback","id":"{_goal(p)}","action":"/fib",'
            '"values":{"partial":[0,1,1]}}'
        ),
    ),
    (
        "action_result",
        _pending(
            "action_result",
            _goal,
            '"action":"/fib","values":{"sequence":[0,1,1,2]},"status":4,"result":true',
        ),
    ),
    (
        "send_action_goal",
        _fixed(
            '{"op":"send_action_goal","id":"action_goal:/serve:1","action":"/serve",'
            '"action_type":"example/action/Fibonacci","args":{"order":4},"feedback":true}'
        ),
    ),
    (
        "cancel_action_goal",
        _fixed('{"op":"cancel_action_goal","id":"action_goal:/serve:1","action":"/serve"}'),
    ),
    ("status", _fixed('{"op":"status","level":"error","msg":"boom","id":"x"}')),
]


def inbound_rows(registry: TypeRegistry, repeats: int) -> list[tuple[str, float, float]]:
    """(op, µs of ClientProtocol.receive, µs of codec_json.loads of the same frame)."""
    rows = []
    for name, setup in INBOUND:
        proto = ClientProtocol(encoding="json", spec_lookup=registry.message)
        proto.subscribe("/imu", "sensor_msgs/msg/Imu")
        proto.subscribe("/raw")
        proto.advertise_service("/add", "example/srv/AddTwoInts")
        proto.advertise_action("/serve", "example/action/Fibonacci")
        state: list[str] = [setup(proto)]

        def prepare(p: ClientProtocol = proto, s: Setup = setup, st: list[str] = state) -> None:
            st[0] = s(p)

        def receive(p: ClientProtocol = proto, st: list[str] = state) -> object:
            return p.receive(st[0], recv_ns=0)

        events = receive()
        assert events and (name == "status" or type(events[0]).__name__ != "Ignored"), events
        frame = state[0].encode()
        rows.append(
            (
                name,
                median_us(receive, repeats, prepare),
                median_us(lambda f=frame: codec_json.loads(f), repeats),
            )
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20_000, help="calls per small op")
    parser.add_argument("--big-repeats", type=int, default=15, help="calls per 4 MB publish")
    parser.add_argument("--points", type=int, default=LIDAR_POINTS)
    args = parser.parse_args(argv)
    registry = TypeRegistry.with_defaults()
    print(f"{'op':36s} {'frame µs':>10s} {'dumps µs':>10s} {'ratio':>6s}")
    for name, built, dumped in op_rows(registry, args.repeats):
        print(f"{name:36s} {built:10.2f} {dumped:10.2f} {built / dumped:6.2f}")
    print(
        f"{'publish (encode_publish vs frames)':36s} {'client µs':>10s} {'frames µs':>10s}"
        f" {'ratio':>6s} {'bytes':>10s}"
    )
    for name, client, shared, size in publish_rows(
        registry, args.points, args.repeats, args.big_repeats
    ):
        print(f"{name:36s} {client:10.1f} {shared:10.1f} {client / shared:6.2f} {size:10d}")
    print(f"{'inbound (receive vs loads)':36s} {'receive µs':>10s} {'loads µs':>10s} {'ratio':>6s}")
    for name, received, loaded in inbound_rows(registry, args.repeats):
        print(f"{name:36s} {received:10.2f} {loaded:10.2f} {received / loaded:6.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
