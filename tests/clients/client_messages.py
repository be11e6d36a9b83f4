"""Helpers shared by the client tests: message builders, rosbridge_suite wire quirks
(float-total fragments, png frames) and waiting for a subscription to carry data."""

from __future__ import annotations

import asyncio
import base64
import io
import math
from typing import Any

import numpy as np
import orjson
from PIL import Image

from clients import Received, RosbridgeClient, Subscription
from schemas.message import default_message
from schemas.pointcloud import pack_points
from schemas.registry import TypeRegistry


def pointcloud(registry: TypeRegistry, n_points: int, seed: int = 0) -> dict[str, Any]:
    """A PointCloud2 of ``n_points`` XYZI float32 points (16 bytes each) in canonical form."""
    points = np.random.default_rng(seed).normal(size=(n_points, 4)).astype(np.float32)
    return pack_points(points, 12_000_000_345, "lidar")


def imu(registry: TypeRegistry, seq: int = 0) -> dict[str, Any]:
    """An Imu with distinct covariances (fixed float64[9] arrays) in canonical form."""
    msg = default_message(registry.message("sensor_msgs/msg/Imu"))
    msg["header"] = {"stamp": {"sec": 100 + seq, "nanosec": 5}, "frame_id": "imu"}
    msg["orientation"] = {"x": 0.0, "y": 0.0, "z": 0.38268343236, "w": 0.92387953251}
    msg["orientation_covariance"] = [0.01 * (i + 1) for i in range(9)]
    msg["angular_velocity"] = {"x": 0.001, "y": -0.002, "z": 0.25}
    msg["angular_velocity_covariance"] = [0.001 * i for i in range(9)]
    msg["linear_acceleration"] = {"x": 0.1, "y": -0.2, "z": 9.81 + seq}
    msg["linear_acceleration_covariance"] = [float(i) for i in range(9)]
    return msg


async def publish_until_received(
    publisher: RosbridgeClient,
    topic: str,
    msg: dict[str, Any],
    sub: Subscription,
    *,
    timeout_s: float = 10.0,
) -> Received:
    """Publish ``msg`` every 50 ms until ``sub`` receives something (subscribe has no ack)."""
    async with asyncio.timeout(timeout_s):
        while True:
            await publisher.publish(topic, msg)
            try:
                return await asyncio.wait_for(sub.get(), 0.05)
            except TimeoutError:
                continue


def rosbridge_fragments(text: str, size: int, frag_id=0) -> list[str]:
    """Fragments exactly as rosbridge cuts them, including its float ``total``."""
    total = (len(text) - 1) / size + 1
    pieces = [text[i : i + size] for i in range(0, len(text), size)]
    assert math.floor(total) == len(pieces)
    return [
        orjson.dumps(
            {"op": "fragment", "id": frag_id, "data": piece, "num": num, "total": total}
        ).decode()
        for num, piece in enumerate(pieces)
    ]


def rosbridge_png(text: str) -> str:
    """The ``png`` op rosbridge sends for ``text`` (protocol §2.11): RGB pixels, \\n padding."""
    raw = text.encode()
    width = math.floor(math.sqrt(len(raw) / 3))
    height = math.ceil(len(raw) / 3 / width)
    raw += b"\n" * (width * height * 3 - len(raw))
    image = Image.frombytes("RGB", (width, height), raw)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return orjson.dumps({"op": "png", "data": base64.b64encode(buffer.getvalue()).decode()})


def publish_text(topic: str, payload: bytes) -> str:
    msg = {
        "header": {"stamp": {"sec": 1, "nanosec": 2}, "frame_id": "lidar"},
        "height": 1,
        "width": len(payload) // 16,
        "point_step": 16,
        "row_step": len(payload),
        "data": base64.b64encode(payload).decode(),
        "is_dense": True,
    }
    return orjson.dumps({"op": "publish", "topic": topic, "msg": msg}).decode()
