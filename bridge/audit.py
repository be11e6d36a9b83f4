"""Plug-in: the audit trail of `--audit-log`, JSON lines written by a thread, rotated by size.

The core's policy (`bridge.roles.Policy.record`) hands each entry to `AuditTrail.write`, which
only puts it on a queue; a `logging.handlers.QueueListener` thread formats nothing more and
appends it through a `RotatingFileHandler`, so the event loop never waits on the disk.
Entries: time (UTC, ISO 8601), principal, role, client node, peer, op, name, outcome and, for
a refusal, the reason (docs/bridge.md, "Roles and tokens").
"""

from __future__ import annotations

import logging
import queue
from logging.handlers import QueueListener, RotatingFileHandler

import orjson

from bridge.host import PluginHost

# A file is rotated at this size; this many earlier files are kept (FILE.1 ... FILE.5).
MAX_BYTES = 10 * 1024 * 1024
BACKUPS = 5


class AuditTrail:
    """Started after the server listens; entries made before are kept in the queue."""

    def __init__(self, host: PluginHost) -> None:
        path = host.config.audit_log
        if path is None:
            raise ValueError("AuditTrail needs config.audit_log")
        self._queue: queue.SimpleQueue[logging.LogRecord] = queue.SimpleQueue()
        self._file = RotatingFileHandler(
            path, maxBytes=MAX_BYTES, backupCount=BACKUPS, encoding="utf-8", delay=True
        )
        self._file.setFormatter(logging.Formatter("%(message)s"))
        self._listener = QueueListener(self._queue, self._file)
        host.set_audit(self.write)

    def write(self, entry: dict[str, object]) -> None:
        """Queue one entry (called on the loop: no I/O here)."""
        line = orjson.dumps(entry, option=orjson.OPT_NON_STR_KEYS).decode("utf-8")
        self._queue.put_nowait(logging.makeLogRecord({"msg": line, "levelno": logging.INFO}))

    async def start(self) -> None:
        self._listener.start()

    async def stop(self) -> None:
        """Write what is queued, then close the file."""
        self._listener.stop()
        self._file.close()


__all__ = ["AuditTrail"]
