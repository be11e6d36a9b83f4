"""The link model without sockets: serialisation at the rate, delay, order, stalls, room."""

from __future__ import annotations

import random

import pytest

from clients.linkemu.profiles import PROFILES, Direction, profile_named
from clients.linkemu.timing import DirectionTiming, StallSchedule


def timing(rate_bps: float = 8e6, delay_ms: float = 10, jitter_ms: float = 0) -> DirectionTiming:
    direction = Direction(
        rate_bps=rate_bps, delay_ms=delay_ms, jitter_ms=jitter_ms, buffer_bytes=100_000
    )
    return DirectionTiming(direction, StallSchedule(0, 0, random.Random(1)), random.Random(1))


def test_bytes_leave_at_the_rate_and_arrive_after_the_delay() -> None:
    link = timing(rate_bps=8e6, delay_ms=10)  # one byte per microsecond
    assert link.transmit(0.0, 1000) == pytest.approx((0.001, 0.011))
    # queued behind the first: starts when the serialiser is free
    assert link.transmit(0.0, 1000) == pytest.approx((0.002, 0.012))
    # an idle link starts at once
    assert link.transmit(1.0, 500) == pytest.approx((1.0005, 1.0105))


def test_jitter_never_reorders() -> None:
    link = timing(rate_bps=1e9, delay_ms=5, jitter_ms=20)
    arrivals = [link.transmit(i * 1e-4, 100)[1] for i in range(1000)]
    assert arrivals == sorted(arrivals)
    extra_ms = [(a - i * 1e-4) * 1000 - 5 for i, a in enumerate(arrivals)]
    assert min(extra_ms) >= 0 and max(extra_ms) <= 20 + 1


def test_a_stall_holds_what_would_cross_it() -> None:
    stalls = StallSchedule(every_s=1.0, length_ms=400, rng=random.Random(3))
    first_start = stalls._next_start_s  # the schedule's first stall
    busy_s = 0.1
    end = stalls.finish(first_start - 0.05, busy_s)
    stall = stalls._stalls[0]
    assert stall.start_s == first_start
    assert end == pytest.approx(stall.end_s + 0.05)  # half before, the rest after the stall
    assert stalls.stalled_s(stall.end_s) == pytest.approx(stall.end_s - stall.start_s)
    assert 0.2 <= stall.end_s - stall.start_s <= 0.6


def test_the_queue_admits_only_what_fits() -> None:
    link = timing(rate_bps=8e6)  # 100_000-byte queue = 0.1 s
    assert link.room_at(0.0, 50_000) == 0.0
    link.transmit(0.0, 100_000)
    assert link.queued_bytes(0.0) == 100_000
    # 50 000 more fit once 50 000 have left: after 0.05 s
    assert link.room_at(0.0, 50_000) == pytest.approx(0.05)


def test_profiles_have_the_documented_figures() -> None:
    four_g = profile_named("4g")
    assert four_g.to_client.rate_bps == 10e6 and four_g.to_client.delay_ms == 30
    assert four_g.stall_every_s > 0
    wifi = profile_named("wifi")
    assert wifi.to_client.rate_bps == 20e6 and wifi.to_client.delay_ms == 10
    assert set(PROFILES) == {"lan", "wifi", "4g"}
    with pytest.raises(KeyError, match="known: lan, wifi, 4g"):
        profile_named("5g")
