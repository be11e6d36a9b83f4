"""Run a fixed script of client frames through `BridgeCore` and print every frame it answers.

`tests/test_native_build.py` runs this twice, once on the compiled hot path and once on the
Python sources (``RIVERBRIDGE_PURE=1``), and the two outputs must be the same bytes: the
compiled modules are the same program. The first line says which modules were compiled.
"""

from __future__ import annotations

import base64
import importlib
import sys

from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.effects import Close, Send
from bridge.outgoing import render
from schemas import codec_cbor, codec_json
from schemas.registry import TypeRegistry
from schemas.runtime import native

NOW = 1_700_000_000_000_000_000
IMU = {
    "header": {"stamp": {"sec": 1_700_000_000, "nanosec": 5}, "frame_id": "imu_link"},
    "orientation": {"x": 0.01, "y": 0.02, "z": 0.7, "w": 0.71},
    "orientation_covariance": [0.01, 0, 0, 0, 0.01, 0, 0, 0, 0.01],
    "angular_velocity": {"x": 0.001, "y": -0.002, "z": 0.05},
    "linear_acceleration": {"x": 0.1, "y": 0.05, "z": 9.81},
}
RADAR = {
    "header": {"stamp": {"sec": 3, "nanosec": 4}, "frame_id": "radar"},
    "detections": [{"range_m": 10.1 + i, "azimuth_rad": 0.1 * i, "x_m": 1e-3} for i in range(3)],
}


def script() -> list[tuple[str, object]]:
    """(who, frame) pairs: text for JSON, bytes for CBOR; good ops and bad ones."""
    return [
        ("sub", {"op": "set_level", "level": "info"}),
        ("pub", {"op": "advertise", "topic": "/chatter", "type": "std_msgs/msg/String"}),
        ("pub", {"op": "advertise", "topic": "/imu", "type": "sensor_msgs/msg/Imu"}),
        ("sub", {"op": "subscribe", "topic": "/chatter", "type": "std_msgs/msg/String"}),
        ("sub", {"op": "subscribe", "topic": "/imu", "compression": "cbor", "id": "i"}),
        ("raw", {"op": "subscribe", "topic": "/imu", "compression": "cbor-raw"}),
        ("raw", {"op": "subscribe", "topic": "/chatter", "fragment_size": 40}),
        ("pub", {"op": "publish", "topic": "/chatter", "msg": {"data": "hello"}}),
        ("pub", codec_cbor.dumps({"op": "publish", "topic": "/chatter", "msg": {"data": "é"}})),
        ("pub", {"op": "publish", "topic": "/chatter", "msg": {"data": "long " * 600}}),
        ("pub", {"op": "publish", "topic": "/imu", "msg": IMU}),
        ("pub", codec_cbor.dumps({"op": "publish", "topic": "/imu", "msg": IMU})),
        ("pub", {"op": "publish", "topic": "/imu", "msg": {**IMU, "orientation": 3}}),
        ("pub", {"op": "publish", "topic": "/chatter", "msg": {"data": 7}, "id": "bad"}),
        (
            "sub",
            {
                "op": "subscribe",
                "topic": "/radar",
                "type": "riverbridge_msgs/msg/RadarDetectionArray",
            },
        ),
        (
            "pub",
            {
                "op": "publish",
                "topic": "/radar",
                "type": "riverbridge_msgs/msg/RadarDetectionArray",
                "msg": RADAR,
            },
        ),
        ("pub", {"op": "no_such_op", "id": 1}),
        ("pub", b"\xa1\x61"),  # a truncated CBOR map
        ("pub", "{not json"),
        ("sub", {"op": "call_service", "service": "/rosapi/topics", "id": "t"}),
        ("sub", {"op": "call_service", "service": "/nobody", "id": "n"}),
        ("pub", {"op": "unadvertise", "topic": "/chatter"}),
        ("sub", {"op": "unsubscribe", "topic": "/imu", "id": "i"}),
    ]


def main() -> int:
    names = [m for m in native.MODULES if native.is_compiled(importlib.import_module(m))]
    print("compiled:", ",".join(names))
    core = BridgeCore(BridgeConfig(), TypeRegistry.with_defaults())
    clients = {who: core.connect(who) for who in ("sub", "raw", "pub")}
    for step, (who, frame) in enumerate(script()):
        wire = frame if isinstance(frame, bytes | str) else codec_json.dumps(frame).decode()
        now = NOW + step * 1_000_000
        for effect in core.receive(clients[who], wire, now, now):
            if isinstance(effect, Send):
                for piece in render(effect.item, effect.fragment_size, f"f{step}"):
                    data = piece.data if piece.text else base64.b64encode(piece.data)
                    print(step, effect.client_id, effect.drop_key, data.decode())
            elif isinstance(effect, Close):
                print(step, "close", effect.client_id, effect.code, effect.reason)
            else:
                print(step, type(effect).__name__, effect)
    return 0


if __name__ == "__main__":
    sys.exit(main())
