"""Answers a client leaves unread cannot be dropped, so they are bounded by closing the client.

Service responses, forwarded requests, action results and status ops are never dropped from a
client's send queue (only topic messages are). A client that keeps asking without reading
would make the bridge hold its answers without end, and answers can be far larger than the
question (a 90-byte call to `/rosapi/topics_and_raw_types` returns every message definition).
The edge charges each undroppable item's wire bytes to the client's `ReplyBudget` when it is
queued and credits them once written; past `limit_bytes` unread the client is closed with 1008
and a reason saying so. One item larger than the budget passes while nothing else waits, so a
single legitimate large request forwarded to a provider never closes it.
"""

from __future__ import annotations

from dataclasses import dataclass

MIB = 1024 * 1024
POLICY_VIOLATION = 1008  # RFC 6455 close code


@dataclass
class ReplyBudget:
    """Undroppable bytes queued for one client and not yet written to its socket."""

    limit_bytes: int
    waiting_bytes: int = 0
    waiting_items: int = 0

    def charge(self, nbytes: int) -> bool:
        """Count one queued answer; False once the client is over its budget."""
        self.waiting_bytes += nbytes
        self.waiting_items += 1
        return self.waiting_items <= 1 or self.waiting_bytes <= self.limit_bytes

    def credit(self, nbytes: int) -> None:
        """One answer was written."""
        self.waiting_bytes -= nbytes
        self.waiting_items -= 1

    def reason(self) -> str:
        """The close reason (at most 123 bytes, as RFC 6455 allows)."""
        return (
            f"{self.waiting_bytes / MIB:.1f} MiB of replies unread "
            f"(limit {self.limit_bytes / MIB:g} MiB)"
        )
