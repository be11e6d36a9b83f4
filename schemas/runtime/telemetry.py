"""A process measuring itself for telemetry: CPU, memory, identity and the shared rhythm."""

from __future__ import annotations

import os
import socket
import time
from collections.abc import AsyncIterator

from schemas.runtime.periodic import ticks
from schemas.tracing import PUBLISH_PERIOD_S, TRACE_PERIOD_S, ProcessIdentity


def this_process(name: str) -> ProcessIdentity:
    """This process as `name`, with its pid and host name."""
    return ProcessIdentity(name, os.getpid(), socket.gethostname())


class ResourceSampler:
    """CPU share since the previous sample (`os.times`) and resident memory (/proc/self/statm)."""

    def __init__(self) -> None:
        self._page_bytes = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
        self._last_cpu_s, self._last_wall_s = self._cpu_s(), time.monotonic()

    @staticmethod
    def _cpu_s() -> float:
        times = os.times()
        return times.user + times.system

    def rss_bytes(self) -> int:
        try:
            with open("/proc/self/statm", "rb") as statm:
                return int(statm.read().split()[1]) * self._page_bytes
        except (OSError, IndexError, ValueError):
            import resource  # not Linux: peak RSS is the best available (kB on Linux/BSD)

            return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    def cpu_percent(self) -> float:
        """Percent of one core used since the previous call (100 = one core busy)."""
        cpu_s, wall_s = self._cpu_s(), time.monotonic()
        elapsed_s = wall_s - self._last_wall_s
        share = (cpu_s - self._last_cpu_s) / elapsed_s if elapsed_s > 0 else 0.0
        self._last_cpu_s, self._last_wall_s = cpu_s, wall_s
        return 100.0 * share


async def telemetry_ticks(
    period_s: float = PUBLISH_PERIOD_S, trace_period_s: float = TRACE_PERIOD_S
) -> AsyncIterator[bool]:
    """Wake every `trace_period_s` (span batches) and say whether stats are due as well (every
    `period_s`, also when the tick that was due was skipped); runs until cancelled. The bridge
    and the client processes share the rhythm, on the one schedule (:mod:`.periodic`)."""
    step_s = min(trace_period_s, period_s)
    ticks_per_stats = max(1, round(period_s / step_s))
    tick = 0
    async for skipped in ticks(step_s, phase=1.0):
        before, tick = tick, tick + 1 + skipped
        yield tick // ticks_per_stats > before // ticks_per_stats
