"""The player's clock (clients/recording/control.py): log time against the loop's clock under
play, pause, speed and seek, and the stamps it shifts."""

from __future__ import annotations

import pytest

from clients.recording.control import NS_PER_S, PlaybackClock

START_NS = 1_700_000_000 * NS_PER_S


def test_playing_at_a_speed_moves_log_time_that_much_faster() -> None:
    clock = PlaybackClock(speed=2.0, log_ns=START_NS, anchor_s=10.0, anchor_wall_ns=5 * NS_PER_S)
    assert clock.position_ns(11.0) == START_NS + 2 * NS_PER_S
    assert clock.delay_s(START_NS + 4 * NS_PER_S, 11.0) == pytest.approx(1.0)
    assert clock.delay_s(START_NS, 11.0) == pytest.approx(-1.0)  # late


def test_pause_holds_the_position_and_play_resumes_from_it() -> None:
    clock = PlaybackClock(speed=1.0, log_ns=START_NS, anchor_s=0.0, anchor_wall_ns=0)
    clock.pause(3.0, 3 * NS_PER_S)
    assert clock.position_ns(100.0) == START_NS + 3 * NS_PER_S
    assert clock.delay_s(START_NS + 4 * NS_PER_S, 100.0) is None  # nothing is due
    clock.play(100.0, 100 * NS_PER_S)
    assert clock.position_ns(101.0) == START_NS + 4 * NS_PER_S


def test_speed_changes_keep_the_position_and_seek_jumps() -> None:
    clock = PlaybackClock(speed=1.0, log_ns=START_NS, anchor_s=0.0, anchor_wall_ns=0)
    clock.set_speed(4.0, 2.0, 2 * NS_PER_S)
    assert clock.position_ns(2.0) == START_NS + 2 * NS_PER_S
    assert clock.position_ns(3.0) == START_NS + 6 * NS_PER_S
    clock.set_speed(0.0, 3.0, 3 * NS_PER_S)  # not a speed: kept
    assert clock.speed == 4.0
    clock.rebase(START_NS + 60 * NS_PER_S, 3.0, 3 * NS_PER_S)
    assert clock.position_ns(3.5) == START_NS + 62 * NS_PER_S


def test_shifted_stamps_keep_their_distance_to_the_log_time_on_todays_clock() -> None:
    wall_ns = 1_800_000_000 * NS_PER_S
    clock = PlaybackClock(speed=2.0, log_ns=START_NS, anchor_s=0.0, anchor_wall_ns=wall_ns)
    # captured 10 ms before the anchor's log time: 5 ms before the anchor at twice the speed
    assert clock.shifted(START_NS - 10_000_000) == wall_ns - 5_000_000


def test_a_seek_holds_time_at_its_target_until_the_pass_starts_there() -> None:
    clock = PlaybackClock(speed=1.0, log_ns=START_NS, anchor_s=0.0, anchor_wall_ns=0)
    target = START_NS + 30 * NS_PER_S
    clock.hold(target, 1.0, NS_PER_S)
    clock.play(1.5, NS_PER_S)  # a play with the seek: still held while reading ahead
    assert clock.position_ns(5.0) == target
    assert clock.delay_s(target, 5.0) is None
    clock.rebase(target, 5.0, 5 * NS_PER_S)  # the pass has its first messages
    assert clock.position_ns(6.0) == target + NS_PER_S
