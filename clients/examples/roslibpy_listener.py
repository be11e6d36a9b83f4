"""Connect roslibpy to a running riverbridge stack and print what it carries.

    riverbridge up                                   # in one terminal
    python clients/examples/roslibpy_listener.py     # in another

roslibpy speaks JSON only, so large topics (the LIDAR scan) arrive base64-encoded; the IMU and
the obstacle map are shown here. Exits 0 after ``--count`` messages of each topic.
"""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Callable
from typing import Any

import roslibpy

Message = dict[str, Any]


def wait_for(
    ros: roslibpy.Ros,
    topic: str,
    type_name: str,
    count: int,
    timeout_s: float,
    show: Callable[[Message], str],
) -> bool:
    """Subscribe, print ``count`` messages with ``show``, unsubscribe; False on timeout."""
    seen: list[Message] = []
    done = threading.Event()

    def on_message(msg: Message) -> None:
        seen.append(msg)
        print(f"{topic}: {show(msg)}", flush=True)
        if len(seen) >= count:
            done.set()

    listener = roslibpy.Topic(ros, topic, type_name, throttle_rate=100)
    listener.subscribe(on_message)
    try:
        return done.wait(timeout_s)
    finally:
        listener.unsubscribe()


def imu_summary(msg: Message) -> str:
    rate = msg["angular_velocity"]
    accel = msg["linear_acceleration"]
    return (
        f"yaw rate {rate['z']:+.3f} rad/s, accel z {accel['z']:+.2f} m/s^2, "
        f"stamp {msg['header']['stamp']['sec']}.{msg['header']['stamp']['nanosec']:09d}"
    )


def grid_summary(msg: Message) -> str:
    info = msg["info"]
    occupied = msg["data"].count(100)
    size = f"{info['width']}x{info['height']} cells of {info['resolution']:.2f} m"
    return f"{size}, {occupied} occupied"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=9090)
    parser.add_argument("--count", type=int, default=3, help="messages per topic")
    parser.add_argument("--timeout", type=float, default=30.0, help="seconds per topic")
    args = parser.parse_args(argv)

    ros = roslibpy.Ros(host=args.host, port=args.port)
    ros.run(timeout=args.timeout)
    try:
        topics = ros.get_topics()
        print(f"{len(topics)} topics: {', '.join(sorted(topics))}", flush=True)
        ok = wait_for(
            ros, "/imu/data", "sensor_msgs/msg/Imu", args.count, args.timeout, imu_summary
        )
        ok = ok and wait_for(
            ros,
            "/nav/obstacle_map",
            "nav_msgs/msg/OccupancyGrid",
            args.count,
            args.timeout,
            grid_summary,
        )
    finally:
        ros.close()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
