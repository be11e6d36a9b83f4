"""`riverbridge report --link PROFILE`: the stack's IMU and LIDAR read ashore, through the link
emulator, with and without the bridge's freshness options (docs/bridge.md, "Over a thin link").

During the measuring window one client per mode connects through a link emulator of its own
(`clients.linkemu`, the same profile: the modes do not share a bottleneck) and subscribes, on
that one connection, to `/imu/data` (cbor) and `/lidar/points` (cbor with the mode's options).
A reference client on the bridge's host counts what was published. Ages run from the message's
capture stamp to the shore client's receipt (one host, one wall clock).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clients.client import RosbridgeClient
from clients.linkemu import LinkEmulator
from clients.report.results import ShoreLink, ShoreMode, ShoreTopic
from clients.subscription import Subscription
from schemas.catalogue import TOPICS
from schemas.tracing import header_stamp_ns

# The modes: a subscriber asking nothing (today's behaviour), one asking for fresh scans, one
# asking for scans that fit (issue 23's measurements)
MODES: Mapping[str, Mapping[str, Any]] = {
    "plain": {},
    "fresh": {"queue_length": 1, "fragment_size": 65536},
    "reduced": {"queue_length": 1, "fragment_size": 65536, "reduce": {"point_budget": "auto"}},
}
IMU, LIDAR = TOPICS["imu"].pair, TOPICS["lidar"].pair


@dataclass
class _Seen:
    """(capture stamp ns, receipt ns) per topic, and the points of each scan received."""

    pairs: dict[str, list[tuple[int, int]]] = field(default_factory=dict)
    points: list[int] = field(default_factory=list)


async def _record(sub: Subscription, seen: _Seen, topic: str) -> None:
    pairs = seen.pairs.setdefault(topic, [])
    async for received in sub:
        stamp = header_stamp_ns(received.msg)
        if stamp is not None:
            pairs.append((stamp, received.recv_ns))
        if topic == LIDAR[0]:
            seen.points.append(int(received.msg["width"]) * int(received.msg["height"]))


class ShoreWatch:
    """The shore clients and the reference client, recording while the `async with` lasts."""

    def __init__(self, profile: str, bridge: tuple[str, int]) -> None:
        self.profile = profile
        self._bridge = bridge
        self._seen = {mode: _Seen() for mode in (*MODES, "reference")}
        self._stack = contextlib.AsyncExitStack()
        self._tasks: list[asyncio.Task[None]] = []

    async def __aenter__(self) -> ShoreWatch:
        host, port = self._bridge
        for seed, (mode, options) in enumerate(MODES.items()):
            link = await self._stack.enter_async_context(
                LinkEmulator(self.profile, (host, port), seed=seed)
            )
            await self._subscribe(f"ws://127.0.0.1:{link.port}", mode, options)
        await self._subscribe(f"ws://{host}:{port}", "reference", {})
        return self

    async def _subscribe(self, url: str, mode: str, options: Mapping[str, Any]) -> None:
        client = await self._stack.enter_async_context(
            RosbridgeClient(url, encoding="cbor", name=f"shore_{mode}", reconnect=False)
        )
        imu = await client.subscribe(*IMU, compression="cbor", maxsize=100_000)
        lidar = await client.subscribe(
            *LIDAR, compression="cbor", maxsize=1000, bytes_as_numpy=True, **options
        )
        seen = self._seen[mode]
        self._tasks += [
            asyncio.create_task(_record(imu, seen, IMU[0])),
            asyncio.create_task(_record(lidar, seen, LIDAR[0])),
        ]

    async def __aexit__(self, *exc: object) -> None:
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        await self._stack.aclose()

    def summary(self, start_ns: int, end_ns: int) -> ShoreLink:
        """What each mode got of the messages captured in [start_ns, end_ns]."""
        reference = self._seen["reference"]
        modes = []
        for mode, options in MODES.items():
            seen = self._seen[mode]
            topics = {
                topic: _topic(topic, seen, reference, start_ns, end_ns)
                for topic in (IMU[0], LIDAR[0])
            }
            kept = float(np.median(seen.points)) if seen.points else None
            modes.append(
                ShoreMode(mode, json.dumps(dict(options)), topics[IMU[0]], topics[LIDAR[0]], kept)
            )
        return ShoreLink(self.profile, tuple(modes))


def _topic(topic: str, seen: _Seen, reference: _Seen, start_ns: int, end_ns: int) -> ShoreTopic:
    pairs = [(s, r) for s, r in seen.pairs.get(topic, []) if start_ns <= s <= end_ns]
    published = {s for s, _ in reference.pairs.get(topic, []) if start_ns <= s <= end_ns}
    ages_ms = np.array([(r - s) / 1e6 for s, r in pairs])
    window_s = (end_ns - start_ns) / 1e9
    return ShoreTopic(
        topic=topic,
        received=len(pairs),
        per_s=len(pairs) / window_s if window_s > 0 else 0.0,
        delivered_share=len({s for s, _ in pairs} & published) / len(published)
        if published
        else None,
        age_p50_ms=float(np.percentile(ages_ms, 50)) if ages_ms.size else None,
        age_p99_ms=float(np.percentile(ages_ms, 99)) if ages_ms.size else None,
    )
