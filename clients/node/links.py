"""A riverbridge process's connections to the bridge: one for bulk data, one for realtime.

One TCP stream delivers in order, so on a single connection an IMU sample waits behind a 5 MB
scan on every hop. The bridge loses nothing and lets small messages of other topics past a
scan it is still working on, but it cannot reorder bytes already on the wire, and on a busy
machine a scan's transfer takes long: `python -m benchmarks.relay --only scan,scan2
--encodings cbor --repeat 6 --interleave` (load 4-7) gave IMU age p99 38.9 ms on one connection
against 12.7 ms with the scan and the IMU on connections of their own (scan p50 25.5 against
22.6 ms). The simulator and the navigation service therefore keep two connections: `bulk` for
the sensor data and results, `realtime` for the small, frequent messages (IMU, odometry, tf,
GNSS, commands). Both record into one `Tracer` and both
announce the process in its telemetry, so the bridge names each connection's fan-outs after
the process (docs/tracing.md).
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from dataclasses import dataclass

from clients.client import RosbridgeClient
from clients.node.telemetry import telemetry
from clients.protocol import Encoding
from clients.tracing import Tracer
from schemas.runtime.process import freeze_startup_heap, tune_process


@dataclass(frozen=True)
class NodeLinks:
    """The connected clients of one process and the tracer they record into."""

    bulk: RosbridgeClient
    realtime: RosbridgeClient
    tracer: Tracer


@contextlib.asynccontextmanager
async def node_links(
    url: str, process: str, *, encoding: Encoding = "cbor", connect_timeout_s: float = 10.0
) -> AsyncIterator[NodeLinks]:
    """Connect `process` to the bridge at `url` twice and publish its telemetry meanwhile.

    Applies the process settings every riverbridge process runs with (`tune_process`) and,
    once connected, freezes the start-up heap: whatever the process built before (a scene,
    imported libraries) is never garbage.
    """
    tune_process()
    tracer = Tracer(process)
    async with (
        RosbridgeClient(
            url, encoding=encoding, name=process, connect_timeout=connect_timeout_s, tracer=tracer
        ) as bulk,
        RosbridgeClient(
            url,
            encoding=encoding,
            name=f"{process}-realtime",
            connect_timeout=connect_timeout_s,
            tracer=tracer,
        ) as realtime,
    ):
        freeze_startup_heap()
        async with telemetry(bulk, tracer, also=[realtime]):
            yield NodeLinks(bulk, realtime, tracer)
