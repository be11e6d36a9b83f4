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

With `--roles` the bridge has a roles file (`bridge.roles`): the same frames, each checked by
the policy (allow-list, token buckets, per-principal counters) before it takes effect.

Usage: python -m benchmarks.core [--frames 50000] [--repeat 5] [--roles]
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

TOPIC, TYPE = "/chatter", "std_msgs/msg/String"


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
    encoding: str, subscribers: int, frames: int, repeat: int, roles: bool = False
) -> float:
    """Median over `repeat` batches of the mean core time per publish frame, in µs."""
    core = BridgeCore(roles_config() if roles else BridgeConfig(), TypeRegistry())
    encode = codec_json.dumps if encoding == "json" else codec_cbor.dumps

    def receive(client: int, op: dict[str, object]) -> None:
        now = time.time_ns()
        core.receive(client, encode(op), now, now)

    for _ in range(subscribers):
        receive(core.connect("sub"), {"op": "subscribe", "topic": TOPIC, "type": TYPE})
    publisher = core.connect("pub")
    receive(publisher, {"op": "advertise", "topic": TOPIC, "type": TYPE})
    frame = encode({"op": "publish", "topic": TOPIC, "msg": {"data": "x" * 100}})
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
    args = parser.parse_args(argv)
    print(f"{'encoding':8s} {'subscribers':>11s} {'µs/frame':>9s} {'frames/s':>10s}")
    for encoding in ("json", "cbor"):
        for subscribers in (1, 10):
            us = per_frame_us(encoding, subscribers, args.frames, args.repeat, args.roles)
            print(f"{encoding:8s} {subscribers:11d} {us:9.2f} {1e6 / us:10,.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
