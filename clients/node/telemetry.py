"""A node's telemetry: its :class:`~clients.tracing.Tracer`'s spans and its process counters
published on the bridge while the node runs.

Span batches go on ``/riverbridge/trace`` four times a second and the process's ProcessStats
on ``/riverbridge/process_stats`` once a second (docs/tracing.md), on the rhythm the bridge
uses too (:func:`schemas.runtime.telemetry.telemetry_ticks`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import AsyncIterator, Callable, Sequence

from clients.client import RosbridgeClient
from clients.tracing import Tracer
from schemas.runtime.telemetry import telemetry_ticks
from schemas.tracing import (
    PUBLISH_PERIOD_S,
    STATS_TOPIC,
    STATS_TYPE,
    TRACE_PERIOD_S,
    TRACE_TOPIC,
    TRACE_TYPE,
)

log = logging.getLogger(__name__)


@contextlib.asynccontextmanager
async def telemetry(
    client: RosbridgeClient,
    tracer: Tracer,
    period_s: float = PUBLISH_PERIOD_S,
    trace_period_s: float = TRACE_PERIOD_S,
    dropped: Callable[[], int] | None = None,
    also: Sequence[RosbridgeClient] = (),
) -> AsyncIterator[None]:
    """Publish ``tracer``'s span batches every ``trace_period_s`` and its stats every
    ``period_s`` through ``client`` meanwhile.

    ``also``: the process's other connections. Each announces the same ProcessStats, because
    the bridge names a connection's fan-out spans by the process that announced itself on it
    (the report counts each stats stamp once). ``dropped`` reports the process's
    dropped-message count (default: all its clients' own). The last batch is published when
    the block ends.
    """
    clients = (client, *also)
    count_dropped = dropped or (lambda: sum(c.dropped for c in clients))
    await client.advertise(TRACE_TOPIC, TRACE_TYPE)
    for each in clients:
        await each.advertise(STATS_TOPIC, STATS_TYPE)

    async def publish_spans() -> None:
        batch = tracer.batch_msg()
        if batch is not None:
            await client.publish(TRACE_TOPIC, batch)

    async def publish_once() -> None:
        await publish_spans()
        stats = tracer.stats_msg(time.time_ns(), count_dropped())
        for each in clients:
            await each.publish(STATS_TOPIC, stats)

    async def loop() -> None:
        async for with_stats in telemetry_ticks(period_s, trace_period_s):
            try:
                await (publish_once() if with_stats else publish_spans())
            except Exception:  # telemetry must never end the process it observes
                log.exception("%s: publishing telemetry failed", tracer.process)

    task = asyncio.create_task(loop(), name=f"{tracer.process} telemetry")
    try:
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
        with contextlib.suppress(Exception):
            await publish_once()
