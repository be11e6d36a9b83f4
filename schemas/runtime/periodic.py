"""The one periodic schedule of every riverbridge process: sensor timers, map and diagnostics
publishing, and the telemetry rhythm of the bridge and the nodes.

A fixed grid of ticks (no drift): after an overrun the next tick starts at once (late), so a
scan that just misses its period costs no tick; only ticks a whole period behind are skipped
and counted, never queued into a burst.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import AsyncIterator, Awaitable, Callable

log = logging.getLogger(__name__)


async def ticks(period_s: float, phase: float = 0.0) -> AsyncIterator[int]:
    """Yield once per tick of a `period_s` grid whose first tick is `phase` periods from now;
    each value is the number of ticks skipped just before it (0 unless the consumer fell a
    whole period behind). Runs until the consumer stops or is cancelled."""
    loop = asyncio.get_running_loop()
    next_s = loop.time() + phase * period_s
    await asyncio.sleep(max(0.0, next_s - loop.time()))
    skipped = 0
    while True:
        yield skipped
        next_s += period_s
        behind_s = loop.time() - next_s
        skipped = int(behind_s / period_s) if behind_s >= period_s else 0
        next_s += skipped * period_s
        await asyncio.sleep(max(0.0, next_s - loop.time()))


async def every(
    period_s: float,
    action: Callable[[], Awaitable[None]],
    phase: float = 0.0,
    on_skipped: Callable[[int], None] | None = None,
) -> None:
    """Await `action` on each tick of :func:`ticks` until cancelled; a failing call is logged
    and the schedule goes on. `on_skipped` hears how many ticks were skipped, when any were."""
    async for skipped in ticks(period_s, phase):
        if skipped and on_skipped is not None:
            on_skipped(skipped)
        try:
            await action()
        except Exception:  # one failed tick must not end the schedule
            log.exception("periodic %s failed", getattr(action, "__qualname__", action))
