"""One client's subscription to one topic: many ids, one delivery per message.

Implements rosbridge's subscription modifiers (protocol §5) with the combined settings of
all the client's ids on the topic: minimum throttle_rate, minimum queue_length, minimum
fragment_size, strongest compression.

* throttle 0, queue 0: every message goes out at once.
* throttle > 0, queue 0: a message goes out if at least `throttle_ms` passed since the last
  one sent, otherwise it is dropped (no trailing delivery).
* queue > 0: the newest `queue_length` messages wait in a deque (oldest dropped) and leave
  one per throttle interval; with throttle 0 they leave at once (the edge's bounded send
  queue then provides the backpressure).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from bridge.outgoing import COMPRESSION_RANK, JSON, TopicMessage
from bridge.reduction import ReduceRequest
from schemas.values import OpId

NS_PER_MS = 1_000_000


@dataclass(frozen=True, slots=True)
class SubscribeSettings:
    """Settings requested by one subscribe id."""

    throttle_ms: int = 0
    queue_length: int = 0
    fragment_size: int | None = None
    compression: str = JSON
    reduce: ReduceRequest | None = None  # riverbridge: a PointCloud2 thinned to fit the link

    @staticmethod
    def known_compression(name: str | None) -> str:
        """Unknown compression names mean JSON (protocol §4.5)."""
        return name if name in COMPRESSION_RANK else JSON


def combine(settings: list[SubscribeSettings]) -> SubscribeSettings:
    """Least common denominator over a client's ids (protocol §5)."""
    fragment_sizes = [s.fragment_size for s in settings if s.fragment_size is not None]
    reductions = {s.reduce for s in settings}
    return SubscribeSettings(
        # reduced only if every id asks for the same reduction: one asking the whole cloud wins
        reduce=reductions.pop() if len(reductions) == 1 else None,
        throttle_ms=min(s.throttle_ms for s in settings),
        queue_length=min(s.queue_length for s in settings),
        fragment_size=min(fragment_sizes) if fragment_sizes else None,
        compression=max((s.compression for s in settings), key=COMPRESSION_RANK.__getitem__),
    )


@dataclass(slots=True)
class Release:
    """Messages to send now and, if some wait, when to call `Subscription.release` again."""

    messages: list[TopicMessage]
    wake_at_ns: int | None = None


class Subscription:
    """The (client, topic) subscription; `spelling` is the topic name as the client wrote it."""

    def __init__(self, topic: str, spelling: str) -> None:
        self.topic = topic
        self.spelling = spelling
        self.ids: dict[OpId, SubscribeSettings] = {}
        self.settings = SubscribeSettings()
        self.dropped = 0
        self.plain = True  # no throttle, no queue_length: each message goes out as it comes
        self._last_sent_ns: int | None = None
        self._queue: deque[TopicMessage] = deque()

    def set_id(self, sub_id: OpId, settings: SubscribeSettings) -> None:
        """Add or overwrite one id's settings (re-subscribing an id replaces it)."""
        self.ids[sub_id] = settings
        self._recombine()

    def remove_id(self, sub_id: OpId) -> None:
        """Forget one id; unknown ids are ignored (protocol §2.5)."""
        if self.ids.pop(sub_id, _MISSING) is not _MISSING and self.ids:
            self._recombine()

    def _recombine(self) -> None:
        self.settings = combine(list(self.ids.values()))
        self.plain = self.settings.throttle_ms == 0 and self.settings.queue_length == 0
        if self.settings.queue_length > 0 and len(self._queue) > self.settings.queue_length:
            excess = len(self._queue) - self.settings.queue_length
            self.dropped += excess
            self._queue = deque(list(self._queue)[excess:])

    @property
    def waiting(self) -> int:
        return len(self._queue)

    def passes(self, now_ns: int) -> bool:
        """Does a new message go out at once, untouched by throttle or queue (then it counts
        as sent)? The fan-out's shortcut past `offer` for the usual subscription."""
        if self.plain and not self._queue:
            self._last_sent_ns = now_ns
            return True
        return False

    def offer(self, message: TopicMessage, now_ns: int) -> Release:
        """Apply throttle and queue to a newly published message."""
        throttle_ns = self.settings.throttle_ms * NS_PER_MS
        if self.settings.queue_length == 0 and not self._queue:
            if throttle_ns == 0 or self._interval_passed(now_ns, throttle_ns):
                self._last_sent_ns = now_ns
                return Release([message])
            self.dropped += 1
            return Release([])
        self._queue.append(message)
        limit = self.settings.queue_length
        if limit > 0 and len(self._queue) > limit:
            self._queue.popleft()
            self.dropped += 1
        return self.release(now_ns)

    def release(self, now_ns: int) -> Release:
        """Send what the throttle allows now; say when the next waiting message may leave."""
        throttle_ns = self.settings.throttle_ms * NS_PER_MS
        ready: list[TopicMessage] = []
        while self._queue and (throttle_ns == 0 or self._interval_passed(now_ns, throttle_ns)):
            ready.append(self._queue.popleft())
            self._last_sent_ns = now_ns
        wake = None
        if self._queue and self._last_sent_ns is not None:
            wake = self._last_sent_ns + throttle_ns
        return Release(ready, wake)

    def _interval_passed(self, now_ns: int, throttle_ns: int) -> bool:
        return self._last_sent_ns is None or now_ns - self._last_sent_ns >= throttle_ns


_MISSING = object()
