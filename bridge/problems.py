"""Bad input costs one short log line, and a flood of it a summary every ten seconds.

Every refused frame or op is worth one line naming client, op, id and problem, with the
client's input echoed short (`schemas.safety`), but a client sending thousands of bad frames
a second must not be able to fill the disk or the terminal. `ProblemLog` keeps one fixed
window per client: the first `LINES_PER_WINDOW` problems are logged in full, the rest only
counted, and when the window ends the core logs one summary ("[/rosbridge_client_7] 4,811
bad frames in the last 10 s, 4,791 not logged"). Sans-I/O like the core: the time is the
`now_ns` of the call, and the window's end is a deadline the edge schedules.
"""

from __future__ import annotations

from dataclasses import dataclass

NS_PER_S = 1_000_000_000
WINDOW_S = 10
LINES_PER_WINDOW = 20  # enough to diagnose a misbehaving client, too few to flood the log


@dataclass
class ProblemLog:
    """One client's problems in the current window."""

    window_start_ns: int = 0
    window_end_ns: int = 0
    count: int = 0
    logged: int = 0

    def note(self, now_ns: int) -> tuple[bool, int | None]:
        """Count one problem at `now_ns`: (log it in full?, deadline to schedule or None).

        The deadline is the window's end, returned once, with the first problem not logged.
        """
        if now_ns >= self.window_end_ns:
            self.window_start_ns, self.window_end_ns = now_ns, now_ns + WINDOW_S * NS_PER_S
            self.count = self.logged = 0
        self.count += 1
        if self.logged < LINES_PER_WINDOW:
            self.logged += 1
            return True, None
        return False, self.window_end_ns if self.count == LINES_PER_WINDOW + 1 else None

    def expired_summary(self, now_ns: int, node: str, what: str = "bad frames") -> str | None:
        """The summary of a window that has ended without its deadline having fired yet."""
        if self.count and now_ns >= self.window_end_ns:
            return self.summary(node, now_ns, what)
        return None

    def summary(self, node: str, now_ns: int, what: str = "bad frames") -> str | None:
        """The line for a window that ended (or a client that left) with problems not logged;
        the next problem starts a new window."""
        total, unlogged = self.count, self.count - self.logged
        span_s = (min(now_ns, self.window_end_ns) - self.window_start_ns) / NS_PER_S
        self.count = self.logged = 0
        self.window_end_ns = 0
        if unlogged <= 0:
            return None
        return f"[{node}] {total:,} {what} in the last {span_s:.3g} s, {unlogged:,} not logged"
