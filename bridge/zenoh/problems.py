"""One clear, rate-limited log line per kind of bad input from the Zenoh graph.

A sample whose payload does not decode, a key naming a type we do not know, an attachment of
the wrong size: each is dropped and said once per `INTERVAL_S` per (topic, problem), with the
count of those dropped silently since. Called from Zenoh's threads and the event loop alike.
"""

from __future__ import annotations

import logging
import threading
import time

INTERVAL_S = 10.0  # a sender repeating the same mistake at sensor rate gets one line per 10 s


class ProblemLog:
    def __init__(self, logger: logging.Logger, interval_s: float = INTERVAL_S) -> None:
        self._logger = logger
        self._interval_s = interval_s
        self._lock = threading.Lock()
        self._last: dict[tuple[str, str], tuple[float, int]] = {}  # -> (said at, dropped since)

    def dropped(self, where: str, kind: str, detail: str) -> None:
        """A sample or query on `where` was dropped because of `kind` (`detail` says more)."""
        now = time.monotonic()
        with self._lock:
            said_at, silent = self._last.get((where, kind), (-self._interval_s, 0))
            if now - said_at < self._interval_s:
                self._last[(where, kind)] = (said_at, silent + 1)
                return
            self._last[(where, kind)] = (now, 0)
        more = f" ({silent} more dropped since the last line)" if silent else ""
        self._logger.warning("Zenoh: %s on %s dropped: %s%s", kind, where, detail, more)
