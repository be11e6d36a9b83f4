"""How fast a client's link drains: goodput measured while the socket is backed up (sans-I/O).

Only a backed-up socket tells the link's rate: an idle one drains as fast as the bridge writes.
The edge reports, at each look, the bytes that have left the socket so far (handed to the
transport minus what the transport and the kernel still hold) and whether anything waited.
Over a window of at least `window_s` during which the socket stayed backed up, the bytes that
left over the time taken are one sample; the estimate follows the samples (EWMA), so it tracks
a link that changes but is not thrown by one stall.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

# Long enough to span several writes of a 10 Mbit/s link (50 ms is 62 kB) and the pacing
# timer's steps; short enough that a new client's first scan does not fill the socket before
# its link is known, and to follow a cellular link whose rate changes within seconds.
WINDOW_S = 0.05
WEIGHT = 0.3  # of the newest sample in the estimate


@dataclass(slots=True)
class GoodputMeter:
    """The link's estimated rate in bytes per second (`rate_bytes_per_s`, None until measured)."""

    window_s: float = WINDOW_S
    weight: float = WEIGHT
    rate_bytes_per_s: float | None = None
    samples: int = 0
    _mark_s: float | None = None
    _mark_bytes: int = 0

    def observe(self, now_s: float, left_bytes: int, backed_up: bool) -> None:
        """`left_bytes`: bytes that have left the socket since the start; `backed_up`: some
        were still waiting at `now_s`."""
        if not backed_up:
            self._mark_s = None
            return
        if self._mark_s is None:
            self._mark_s, self._mark_bytes = now_s, left_bytes
            return
        elapsed_s = now_s - self._mark_s
        if elapsed_s < self.window_s:
            return
        sample = (left_bytes - self._mark_bytes) / elapsed_s
        old = self.rate_bytes_per_s
        self.rate_bytes_per_s = sample if old is None else old + self.weight * (sample - old)
        self.samples += 1
        self._mark_s, self._mark_bytes = now_s, left_bytes

    def bytes_in(self, seconds: float, default: int) -> int:
        """What the link drains in `seconds` at the estimated rate (`default` if unmeasured)."""
        rate = self.rate_bytes_per_s
        return default if rate is None else int(rate * seconds)


@dataclass(frozen=True)
class LinkHealth:
    """How one client's link is doing, for `/metrics` and the dashboard: its measured goodput
    (None until measured), the round trip of the websocket's last keepalive ping (0 before the
    first), the bytes handed on but not yet sent, the room it is given, and the messages per
    topic its `queue_length` conflated and its `reduce` thinned."""

    goodput_bytes_per_s: float | None
    rtt_s: float
    unsent_bytes: int
    room_bytes: int
    conflated: Mapping[str, int] = field(default_factory=dict)
    reduced: Mapping[str, int] = field(default_factory=dict)
