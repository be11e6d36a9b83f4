"""Large messages leave for Zenoh through one thread, newest first, whole or not at all.

A scan on a thin link takes longer to send than the next one takes to come. Put with Zenoh's
*drop* congestion control from the event loop, its fragments overflow Zenoh's queue and are
cut off: the receiver discards the incomplete scan and the link carried it for nothing
(measured: no scan at all reached the shore). So a large message is put with *block* on this
thread, where waiting costs the loop nothing, and while it waits only the newest message of
each topic stays queued (`bridge.dds.outbox.Outbox` with one item a stream): the shore gets
whole, fresh scans, as many as the link carries. Encoding to CDR happens here too.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from bridge.dds.outbox import Outbox, WriterThread

logger = logging.getLogger("bridge.zenoh")

# Any number of bytes: the one-item bound is what keeps only the newest.
_NO_BYTE_BOUND = 1 << 62


class BulkWriter:
    """Runs each topic's newest put job on one thread (the DDS mirror's `WriterThread`);
    `outbox.dropped` counts the replaced ones."""

    def __init__(self) -> None:
        self.outbox = Outbox(max_items=1, max_bytes=_NO_BYTE_BOUND)
        self._writer = WriterThread(
            self.outbox, "bridge-zenoh-bulk", "Zenoh: a large message was not sent", logger
        )
        self._writer.start()

    def put(self, topic: str, job: Callable[[], None], size: int) -> None:
        self.outbox.put(topic, job, size)

    def close(self) -> None:
        self._writer.stop()
