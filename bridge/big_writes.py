"""Large frames fanned out take turns: at most `slots` links hand one to their sockets at once.

A 5.5 MB scan for sixteen subscribers handed to sixteen sockets in one go makes every
subscriber wait for all sixteen copies (they share the cores and the memory bandwidth), and an
IMU sample queued behind the scan in each socket waits as long. Handed out a few at a time, the
first subscribers have their scan after a sixteenth of that time, the median after half, and a
link still waiting for its turn sends its small messages at once (its queue sends small items
before large ones). A turn ends when the link's unsent bytes are back within its room, or after
`TURN_S` at most, so a subscriber that reads slowly or not at all holds nobody up for longer.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

# Frames from this size on take turns (the transport's own high-water mark: smaller frames go
# out in one write anyway).
BIG_BYTES = 1024 * 1024
SLOTS = 2  # links writing a large frame at once: the machine has 2 cores
TURN_S = 0.02  # longest turn: about what a reading client on loopback takes for a 5 MB frame

Wake = Callable[[], None]


class BigWriteTurns:
    """Who may hand a large frame to its socket now; the others wait in order of asking."""

    def __init__(self, slots: int = SLOTS, turn_s: float = TURN_S) -> None:
        self.slots = slots
        self.turn_s = turn_s
        self._holders: dict[int, asyncio.TimerHandle] = {}  # link id -> end of its turn
        self._waiting: dict[int, Wake] = {}  # link id -> how to tell it its turn came

    def holds(self, link_id: int) -> bool:
        return link_id in self._holders

    def take(self, link_id: int, wake: Wake) -> bool:
        """May link `link_id` write a large frame now? If not, `wake` is called when it may."""
        if link_id in self._holders:
            return True
        if len(self._holders) < self.slots and not self._waiting:
            self._start(link_id)
            return True
        self._waiting.setdefault(link_id, wake)
        return False

    def release(self, link_id: int) -> None:
        """The link's turn is over (its frame has left, or it has gone): wake the next."""
        timer = self._holders.pop(link_id, None)
        if timer is not None:
            timer.cancel()
        self._waiting.pop(link_id, None)
        while self._waiting and len(self._holders) < self.slots:
            next_id, wake = next(iter(self._waiting.items()))
            del self._waiting[next_id]
            self._start(next_id)
            asyncio.get_running_loop().call_soon(wake)

    def _start(self, link_id: int) -> None:
        loop = asyncio.get_running_loop()
        self._holders[link_id] = loop.call_later(self.turn_s, self.release, link_id)
