"""When each chunk of bytes leaves the bottleneck and when it arrives (sans-I/O: times in).

A direction of the link is a serialiser of `rate_bps` fed by a queue: a chunk starts when the
serialiser is free, takes `8 * n / rate_bps` seconds of link time (stalls add their length
when they overlap), then travels `delay + jitter`. Arrivals keep their order, as on one path.
The queue is the bytes whose serialisation has not ended; the proxy reads its source only
while they fit in `buffer_bytes`, so a full queue pushes back on the sender through TCP.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

from clients.linkemu.profiles import Direction


@dataclass(frozen=True, slots=True)
class Stall:
    """The link carries nothing from `start_s` to `end_s` (emulator time)."""

    start_s: float
    end_s: float


class StallSchedule:
    """Stalls of one link, drawn lazily from `rng` and shared by both directions."""

    def __init__(self, every_s: float, length_ms: float, rng: random.Random) -> None:
        self._every_s = every_s
        self._length_s = length_ms / 1000
        self._rng = rng
        self._stalls: list[Stall] = []
        self._next_start_s = self._draw_gap()

    def _draw_gap(self) -> float:
        return self._rng.expovariate(1 / self._every_s) if self._every_s > 0 else float("inf")

    def _extend_to(self, until_s: float) -> None:
        while self._next_start_s <= until_s:
            length_s = self._length_s * self._rng.uniform(0.5, 1.5)
            stall = Stall(self._next_start_s, self._next_start_s + length_s)
            self._stalls.append(stall)
            self._next_start_s = stall.end_s + self._draw_gap()

    def finish(self, start_s: float, busy_s: float) -> float:
        """When `busy_s` of link time begun at `start_s` ends, the stalls it meets added."""
        now_s, left_s = start_s, busy_s
        while True:
            self._extend_to(now_s + left_s)
            stall = next((s for s in self._stalls if s.end_s > now_s), None)
            if stall is None or stall.start_s >= now_s + left_s:
                return now_s + left_s
            left_s -= max(0.0, stall.start_s - now_s)
            now_s = stall.end_s

    def stalled_s(self, until_s: float) -> float:
        """Seconds of stall before `until_s` (for the emulator's statistics)."""
        return sum(min(s.end_s, until_s) - s.start_s for s in self._stalls if s.start_s < until_s)

    def forget_before(self, time_s: float) -> None:
        """Drop stalls that ended before `time_s` (keeps the list short on long runs)."""
        self._stalls = [s for s in self._stalls if s.end_s > time_s]


class DirectionTiming:
    """The serialiser, propagation and queue of one direction."""

    def __init__(self, direction: Direction, stalls: StallSchedule, rng: random.Random) -> None:
        self.direction = direction
        self._stalls = stalls
        self._rng = rng
        self._byte_s = 8 / direction.rate_bps
        self._free_at_s = 0.0  # the serialiser is busy until then
        self._last_arrival_s = 0.0

    def transmit(self, now_s: float, nbytes: int) -> tuple[float, float]:
        """Queue `nbytes` at `now_s`; return (serialised at, arrives at) in seconds."""
        start_s = max(now_s, self._free_at_s)
        sent_s = self._stalls.finish(start_s, nbytes * self._byte_s)
        self._free_at_s = sent_s
        jitter_s = self._rng.uniform(0, self.direction.jitter_ms) / 1000
        arrive_s = max(self._last_arrival_s, sent_s + self.direction.delay_ms / 1000 + jitter_s)
        self._last_arrival_s = arrive_s
        return sent_s, arrive_s

    def queued_bytes(self, now_s: float) -> int:
        """Bytes not yet serialised at `now_s` (an estimate across stalls)."""
        return max(0, int((self._free_at_s - now_s) / self._byte_s))

    def room_at(self, now_s: float, nbytes: int) -> float:
        """The earliest time `nbytes` more fit in the queue (`now_s` if they fit now)."""
        room_s = (self.direction.buffer_bytes - nbytes) * self._byte_s
        return max(now_s, self._free_at_s - room_s)

    def chunk_bytes(self) -> int:
        """Bytes read from the source at once: two milliseconds of link time, 1500 to 64 KiB."""
        return max(1500, min(65536, int(self.direction.rate_bps / 8 / 500)))
