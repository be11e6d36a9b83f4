"""What `riverbridge up` does when a component dies: whether to restart it, after how long, and
the counts it publishes (latched `/riverbridge/restarts`, `schemas.supervision`).

- `RestartPolicy`: `on-failure` (default) restarts a component that exits with a non-zero
  code or a signal, `always` also one that exits 0, `never` stops the stack (the old `up`).
- `RestartBackoff`: 0.25 s before the first restart, doubling up to 30 s while a component
  keeps dying within a minute of its start; a component that ran a minute starts over at
  0.25 s. The simulator and navigation reconnect to a restarted bridge by themselves.
- `RestartLedger`: restarts per component, published through the bridge by a client of its
  own, so the dashboard and `GET /metrics` show them.
"""

from __future__ import annotations

import contextlib
import logging
import time
from dataclasses import dataclass, field, replace
from typing import Literal

from clients.client import RosbridgeClient
from clients.connection import TransportConfig
from clients.errors import RosbridgeError
from schemas.supervision import (
    RESTARTS_TOPIC,
    RESTARTS_TYPE,
    ComponentRestarts,
    restarts_msg,
)

log = logging.getLogger("clients.stack.launcher")

RestartMode = Literal["on-failure", "always", "never"]
RESTART_MODES: tuple[RestartMode, ...] = ("on-failure", "always", "never")
INITIAL_DELAY_S = 0.25  # short: the sensors should flow again within seconds of a crash
MAX_DELAY_S = 30.0  # a crash loop costs at most one start every 30 s
STABLE_AFTER_S = 60.0  # a component that ran this long is healthy again: backoff resets


@dataclass(frozen=True)
class RestartPolicy:
    mode: RestartMode = "on-failure"

    def restarts(self, exit_code: int) -> bool:
        """Is a component that ended with `exit_code` (negative: a signal) restarted?"""
        if self.mode == "never":
            return False
        return self.mode == "always" or exit_code != 0


@dataclass
class RestartBackoff:
    """The delay before restarting one component, from how long its last run lasted."""

    delay_s: float = INITIAL_DELAY_S

    def next_delay(self, ran_s: float) -> float:
        if ran_s >= STABLE_AFTER_S:
            self.delay_s = INITIAL_DELAY_S
        delay, self.delay_s = self.delay_s, min(self.delay_s * 2, MAX_DELAY_S)
        return delay


@dataclass
class RestartLedger:
    """Restarts per component (by title) and their publication through the bridge."""

    components: dict[str, ComponentRestarts] = field(default_factory=dict)
    _client: RosbridgeClient | None = None

    def started(self, title: str, pid: int) -> None:
        state = self.components.get(title, ComponentRestarts())
        self.components[title] = replace(state, pid=pid)

    def died(self, title: str, how: str) -> int:
        """Count a restart of `title` whose last run ended `how`; the count so far."""
        state = self.components.get(title, ComponentRestarts())
        self.components[title] = replace(state, restarts=state.restarts + 1, last_exit=how)
        return state.restarts + 1

    async def attach(self, url: str, transport: TransportConfig | None = None) -> None:
        """Connect a client of the ledger's own and publish the counts (latched)."""
        client = RosbridgeClient(url, encoding="json", name="up-supervisor", transport=transport)
        await client.connect()
        await client.advertise(RESTARTS_TOPIC, RESTARTS_TYPE, latch=True)
        self._client = client
        await self.publish()

    async def publish(self) -> None:
        """Send the current counts; while the bridge restarts the client resends them later."""
        if self._client is None:
            return
        try:
            await self._client.publish(
                RESTARTS_TOPIC, restarts_msg(self.components, time.time_ns())
            )
        except RosbridgeError as exc:
            log.warning("cannot publish the restart counts: %s", exc)

    async def close(self) -> None:
        if self._client is not None:
            with contextlib.suppress(RosbridgeError):
                await self._client.close()
            self._client = None
