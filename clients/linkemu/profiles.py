"""Link profiles: the rates, delays, jitter, bottleneck buffer and stalls of a vessel's link.

The bridge runs aboard; a client ashore reads through the link, so `to_client` is the
vessel's uplink (the narrow direction on cellular) and `to_server` the shore's downlink.
Figures and their sources: docs/linkemu.md.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

MBIT = 1_000_000


class Direction(BaseModel):
    """One direction of the link: a bottleneck of `rate_bps` with a queue of `buffer_bytes`,
    then `delay_ms` of propagation plus up to `jitter_ms` more (delivery stays in order)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    rate_bps: float = Field(gt=0)
    delay_ms: float = Field(ge=0)
    jitter_ms: float = Field(default=0.0, ge=0)
    buffer_bytes: int = Field(gt=0)


class LinkProfile(BaseModel):
    """Both directions and the stalls (the link carries nothing for a while, both ways).

    Stalls start at exponentially distributed intervals of mean `stall_every_s` (0: none)
    and last between half and one and a half times `stall_ms`.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    to_client: Direction
    to_server: Direction
    stall_every_s: float = Field(default=0.0, ge=0)
    stall_ms: float = Field(default=0.0, ge=0)


def _buffer(rate_bps: float, queue_ms: float) -> int:
    """A bottleneck queue holding `queue_ms` of traffic at `rate_bps`."""
    return max(1500, int(rate_bps / 8 * queue_ms / 1000))


def _direction(rate_mbit: float, delay_ms: float, jitter_ms: float, queue_ms: float) -> Direction:
    rate_bps = rate_mbit * MBIT
    return Direction(
        rate_bps=rate_bps,
        delay_ms=delay_ms,
        jitter_ms=jitter_ms,
        buffer_bytes=_buffer(rate_bps, queue_ms),
    )


# docs/linkemu.md gives each figure's source.
PROFILES: dict[str, LinkProfile] = {
    # Switched gigabit Ethernet on board or in the harbour office.
    "lan": LinkProfile(
        name="lan",
        to_client=_direction(1000, 0.1, 0.0, 2),
        to_server=_direction(1000, 0.1, 0.0, 2),
    ),
    # 802.11n/ac across a quay: about 20 Mbit/s of goodput, 10 ms each way, a few ms jitter.
    "wifi": LinkProfile(
        name="wifi",
        to_client=_direction(20, 10, 5, 30),
        to_server=_direction(20, 10, 5, 30),
    ),
    # LTE from a vessel near the coast: about 10 Mbit/s up, 30 Mbit/s down, 30 ms each way,
    # 10 ms jitter, and a stall of about 0.3 s a minute (cell changes, fading).
    "4g": LinkProfile(
        name="4g",
        to_client=_direction(10, 30, 10, 30),
        to_server=_direction(30, 30, 10, 30),
        stall_every_s=60.0,
        stall_ms=300.0,
    ),
}


def profile_named(name: str) -> LinkProfile:
    """The profile called `name`; KeyError names the known ones."""
    try:
        return PROFILES[name]
    except KeyError:
        raise KeyError(f"unknown link profile {name!r} (known: {', '.join(PROFILES)})") from None
