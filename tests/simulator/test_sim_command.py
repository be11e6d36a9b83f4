"""simulator.command: the operator over the autopilot, zero thrust after a silence, counted."""

from __future__ import annotations

from simulator.command import CommandArbiter
from simulator.config import CommandConfig
from simulator.dynamics import Command

S = 1_000_000_000
AUTO, PERSON = Command(3000.0, 100.0), Command(-500.0, 0.0)


def test_the_autopilot_drives_until_it_falls_silent_then_zero_is_counted():
    arbiter = CommandArbiter(CommandConfig(timeout_s=1.0))
    assert arbiter.current(0) == (Command(), "none")
    arbiter.autopilot(AUTO, stamp_ns=5, now_ns=0)
    assert arbiter.current(S // 2) == (AUTO, "autopilot")
    assert arbiter.timeouts == 0
    assert arbiter.current(S + 1) == (Command(), "none")
    assert arbiter.timeouts == 1
    assert arbiter.current(2 * S) == (Command(), "none")
    assert arbiter.timeouts == 1  # one silence, one count


def test_a_person_overrides_the_autopilot_for_the_override_time():
    arbiter = CommandArbiter(CommandConfig(timeout_s=1.0, operator_override_s=5.0))
    arbiter.autopilot(AUTO, stamp_ns=1, now_ns=0)
    arbiter.current(0)
    arbiter.operator(PERSON, now_ns=S)
    assert arbiter.current(S) == (PERSON, "operator")
    assert arbiter.overrides == 1
    arbiter.autopilot(AUTO, stamp_ns=2, now_ns=3 * S)
    # the person fell silent: zero thrust, the autopilot still held off
    assert arbiter.current(3 * S) == (Command(), "operator")
    arbiter.autopilot(AUTO, stamp_ns=3, now_ns=6 * S)
    assert arbiter.current(6 * S + 1) == (AUTO, "autopilot")


def test_each_autopilot_command_is_reported_applied_once():
    arbiter = CommandArbiter(CommandConfig())
    arbiter.autopilot(AUTO, stamp_ns=42, now_ns=10)
    arbiter.current(20)
    applied = arbiter.take_applied()
    assert applied is not None and (applied.stamp_ns, applied.received_ns) == (42, 10)
    arbiter.current(40)
    assert arbiter.take_applied() is None
