"""Taking messages off a client library `Subscription` in tests, bounded in time."""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from clients.subscription import Subscription


async def collect(
    sub: Subscription, count: int, timeout_s: float = 10.0, grace_s: float = 0.0
) -> list[dict[str, Any]]:
    """The first `count` messages (fewer if `timeout_s` runs out), plus whatever arrives in
    the `grace_s` after them (where a duplicate would show)."""
    received: list[dict[str, Any]] = []
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(timeout_s):
            async for item in sub:
                received.append(item.msg)
                if len(received) >= count:
                    break
    return received + (await drain(sub, grace_s) if grace_s > 0 else [])


async def drain(sub: Subscription, seconds: float) -> list[dict[str, Any]]:
    """Every message that arrives in the next `seconds`."""
    received: list[dict[str, Any]] = []
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(seconds):
            async for item in sub:
                received.append(item.msg)
    return received


async def surge_speed_reaches(odom: Subscription, target_mps: float, timeout_s: float) -> float:
    """The vessel's surge speed from `/odom` (nav_msgs/msg/Odometry) once it reaches
    `target_mps`; the last one seen if it does not in `timeout_s`."""
    speed = 0.0
    async with asyncio.timeout(timeout_s):
        async for item in odom:
            speed = item.msg["twist"]["twist"]["linear"]["x"]
            if speed >= target_mps:
                return speed
    return speed
