"""The goodput meter: only a backed-up socket's draining counts, over whole windows."""

from __future__ import annotations

import pytest

from bridge.goodput import GoodputMeter


def test_unmeasured_until_a_backed_up_window_ends():
    meter = GoodputMeter(window_s=0.1)
    assert meter.bytes_in(0.02, default=1_000_000) == 1_000_000
    meter.observe(0.0, 0, backed_up=True)
    meter.observe(0.05, 50_000, backed_up=True)
    assert meter.rate_bytes_per_s is None
    meter.observe(0.125, 156_250, backed_up=True)
    assert meter.rate_bytes_per_s == pytest.approx(1_250_000)  # 10 Mbit/s
    assert meter.bytes_in(0.02, default=1_000_000) == 25_000


def test_an_idle_moment_restarts_the_window():
    """An idle socket drains as fast as the bridge writes: that says nothing of the link."""
    meter = GoodputMeter(window_s=0.1)
    meter.observe(0.0, 0, backed_up=True)
    meter.observe(0.05, 10_000, backed_up=False)
    meter.observe(0.5, 10_000, backed_up=True)
    meter.observe(0.625, 135_000, backed_up=True)
    assert meter.rate_bytes_per_s == pytest.approx(1_000_000)


def test_the_estimate_follows_the_link_without_jumping():
    meter = GoodputMeter(window_s=0.1, weight=0.5)
    meter.observe(0.0, 0, backed_up=True)
    meter.observe(0.125, 125_000, backed_up=True)  # 1 MB/s
    meter.observe(0.25, 375_000, backed_up=True)  # 2 MB/s
    assert meter.rate_bytes_per_s == pytest.approx(1_500_000)
    assert meter.samples == 2
