"""Reconnect delays: exponential backoff with jitter.

The bridge may start after its clients, or restart under a running simulator; every client then
retries. Exponential growth keeps a dead bridge from being hammered, jitter keeps a fleet of
clients from reconnecting in lock-step, and a small first delay lets a restarted bridge be
rejoined within a fraction of a second.
"""

from __future__ import annotations

import random
from collections.abc import Iterator

from pydantic import BaseModel, ConfigDict, Field, model_validator


class BackoffPolicy(BaseModel):
    """Delays between connection attempts, in seconds.

    Attempt k (from 0) waits ``min(max_s, initial_s * factor**k)`` scaled by a random factor
    in ``[1 - jitter, 1]`` ("equal jitter" when 0.5). Defaults: roslibpy starts at 1 s with
    factor ~2.7 (reference/rosbridge-clients.md §2); we start at 0.1 s because a restarted
    local bridge is back within milliseconds, and cap at 2 s so a simulator resumes within
    about 2 s of the bridge returning (a refused local connect costs microseconds, so the
    extra attempts are free).
    """

    model_config = ConfigDict(frozen=True)

    initial_s: float = Field(default=0.1, gt=0)
    max_s: float = Field(default=2.0, gt=0)
    factor: float = Field(default=2.0, ge=1.0)
    jitter: float = Field(default=0.5, ge=0.0, le=1.0)

    @model_validator(mode="after")
    def _initial_below_max(self) -> BackoffPolicy:
        if self.initial_s > self.max_s:
            raise ValueError("initial_s must not exceed max_s")
        return self

    def delays(self, rng: random.Random) -> Iterator[float]:
        """Endless sequence of delays in seconds; ``rng`` supplies the jitter."""
        base_s = self.initial_s
        while True:
            yield base_s * (1.0 - self.jitter * rng.random())
            base_s = min(self.max_s, base_s * self.factor)
