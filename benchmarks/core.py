"""What the bridge's sans-I/O core costs per published frame, without sockets or an event loop.

`BridgeCore.receive` is called directly with a ~100-byte ``std_msgs/String`` publish (JSON
as a binary frame, as ROS# sends it, and CBOR) while 1 or 10 clients subscribe; the effects
it returns are dropped, so this is the core's share of the relay benchmark's per-message time
(decode, checks, typed dispatch, validation, fan-out), the part the bridge's own code decides.
Prints the median over ``--repeat`` batches of the mean microseconds per frame, and frames/s.

Measured here (quiet, load < 0.3; two runs each, µs per frame, JSON / CBOR, 1 subscriber):
the session's start (a243925) 9.0-9.9 / 9.7-10.2; with typed routes and the frame's facts
on the core call 10.6 / 11.6; with the two per-frame value objects (`InboundFrame`,
`ValidMessage`) no longer frozen dataclasses 9.3-9.8 / 10.7-11.2. 10 subscribers: 25-28 µs
in all three.
Issue 21 (min of 3 interleaved runs, load ~1, the VM slower that day): with `Send`, `Delivery`
and `WireFrame` no longer frozen and `fragment_size_for` without lists, 1 subscriber JSON 14.2
-> 12.0, CBOR 16.1 -> 14.0; 10 subscribers 35.0 -> 23.5 and 38.5 -> 24.8.

Compiled by mypyc (`schemas.runtime.native`) against `RIVERBRIDGE_PURE=1` (issue 21, noisy VM,
best of runs, µs per frame, 1 subscriber): String JSON 10.2-12.0 / 13.9-18.6, CBOR 7.6-9.8 /
11.1-17.8; Imu JSON 11.7 / 16.2, CBOR 18.8 / 23.1.

With `--roles` the bridge has a roles file (`bridge.roles`): the same frames, each checked by
the policy (allow-list, token buckets, per-principal counters) before it takes effect.

Usage: python -m benchmarks.core [--frames 50000] [--repeat 5] [--roles] [--messages string,imu]
"""

from __future__ import annotations

import argparse
import statistics
import time

from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from schemas import codec_cbor, codec_json
from schemas.registry import TypeRegistry
from schemas.roles_config import RolesConfig

TOPIC = "/chatter"
#: The messages to publish: a ~100-byte String, and a full Imu (a header and 45 numbers, the
#: 50-200 Hz message whose check the compiled check takes over: `schemas.compiled_check`).
MESSAGES: dict[str, tuple[str, dict[str, object]]] = {
    "string": ("std_msgs/msg/String", {"data": "x" * 100}),
    "imu": (
        "sensor_msgs/msg/Imu",
        {
            "header": {"stamp": {"sec": 1_700_000_000, "nanosec": 5}, "frame_id": "imu_link"},
            "orientation": {"x": 0.01, "y": 0.02, "z": 0.7, "w": 0.71},
            "orientation_covariance": [0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01],
            "angular_velocity": {"x": 0.001, "y": -0.002, "z": 0.05},
            "angular_velocity_covariance": [0.001, 0, 0, 0, 0.001, 0, 0, 0, 0.001],
            "linear_acceleration": {"x": 0.1, "y": 0.05, "z": 9.81},
            "linear_acceleration_covariance": [0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1],
        },
    ),
}


def roles_config() -> BridgeConfig:
    """A bridge with `--roles`: the publisher's role allows its topic, with quotas it never
    reaches (so the policy's whole check, token buckets included, runs on every frame)."""
    roles = RolesConfig.model_validate(
        {
            "roles": {
                "sensor": {
                    "publish": ["/chatter", "/imu*"],
                    "subscribe": ["*"],
                    "limits": {"messages_per_s": 1e9, "bytes_per_s": 1e12},
                }
            },
            "unauthenticated_role": "sensor",
        }
    )
    return BridgeConfig(roles=roles)


def per_frame_us(
    encoding: str,
    subscribers: int,
    frames: int,
    repeat: int,
    roles: bool = False,
    message: str = "string",
) -> float:
    """Median over `repeat` batches of the mean core time per publish frame, in µs."""
    core = BridgeCore(roles_config() if roles else BridgeConfig(), TypeRegistry())
    encode = codec_json.dumps if encoding == "json" else codec_cbor.dumps

    def receive(client: int, op: dict[str, object]) -> None:
        now = time.time_ns()
        core.receive(client, encode(op), now, now)

    type_name, msg = MESSAGES[message]
    for _ in range(subscribers):
        receive(core.connect("sub"), {"op": "subscribe", "topic": TOPIC, "type": type_name})
    publisher = core.connect("pub")
    receive(publisher, {"op": "advertise", "topic": TOPIC, "type": type_name})
    frame = encode({"op": "publish", "topic": TOPIC, "msg": msg})
    batches = []
    for batch in range(repeat + 1):
        start = time.perf_counter_ns()
        for _ in range(frames):
            now = time.time_ns()
            core.receive(publisher, frame, now, now)
        if batch:  # the first batch warms up
            batches.append((time.perf_counter_ns() - start) / frames / 1e3)
    return statistics.median(batches)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50_000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument(
        "--roles", action="store_true", help="with a roles file: the policy checks every frame"
    )
    parser.add_argument(
        "--messages",
        default="string",
        help=f"comma-separated, of {', '.join(MESSAGES)} (default: string)",
    )
    args = parser.parse_args(argv)
    messages = [name.strip() for name in args.messages.split(",") if name.strip()]
    unknown = [name for name in messages if name not in MESSAGES]
    if unknown or not messages:
        choices = ", ".join(MESSAGES)
        parser.error(f"--messages: unknown {unknown or messages}; choose from {choices}")
    print(f"{'message':8s} {'encoding':8s} {'subscribers':>11s} {'µs/frame':>9s} {'frames/s':>10s}")
    for message in messages:
        for encoding in ("json", "cbor"):
            for subscribers in (1, 10):
                us = per_frame_us(
                    encoding, subscribers, args.frames, args.repeat, args.roles, message
                )
                print(f"{message:8s} {encoding:8s} {subscribers:11d} {us:9.2f} {1e6 / us:10,.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
