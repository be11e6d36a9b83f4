"""Who drives the thrusters: the operator, the autopilot, or (after a silence) nobody.

A pure state machine (no clock, no socket: `now_ns` is passed in), so every rule is unit-tested:

- a person's `/cmd_wrench` (teleop, the dashboard) beats the autopilot's
  `/guidance/cmd_wrench` for `operator_override_s` after the person's latest command;
- a source that has said nothing for `timeout_s` no longer counts; when no source counts, the
  command is zero thrust. Each fall to zero from a live command is counted (`timeouts`), so a
  killed autopilot stops the vessel (it coasts to rest on its damping) instead of driving on
  with its last demand.
- the autopilot's commands carry their tick's stamp; the first physics step that applies one
  reports it once (`take_applied`), for the `actuate` trace span (docs/guidance.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from simulator.config import CommandConfig
from simulator.dynamics import Command

Source = Literal["operator", "autopilot", "none"]
NS_PER_S = 1_000_000_000


@dataclass(frozen=True)
class Applied:
    """An autopilot command on its first physics step: its stamp and when it arrived."""

    stamp_ns: int
    received_ns: int


class CommandArbiter:
    """Holds the newest command of each source and decides which one the physics applies."""

    def __init__(self, cfg: CommandConfig) -> None:
        self.cfg = cfg
        self._operator: tuple[Command, int] | None = None
        self._autopilot: tuple[Command, int] | None = None
        self._unapplied: Applied | None = None
        self.source: Source = "none"
        self.timeouts = 0
        self.overrides = 0
        self._live = False

    def operator(self, command: Command, now_ns: int) -> None:
        """A person's command arrived."""
        self._operator = (command, now_ns)

    def autopilot(self, command: Command, stamp_ns: int, now_ns: int) -> None:
        """The autopilot's command of tick `stamp_ns` arrived."""
        self._autopilot = (command, now_ns)
        self._unapplied = Applied(stamp_ns, now_ns)

    def current(self, now_ns: int) -> tuple[Command, Source]:
        """The command to apply now and whose it is; counts timeouts and overrides."""
        timeout_ns = self.cfg.timeout_s * NS_PER_S
        operator_fresh = _within(self._operator, now_ns, timeout_ns)
        autopilot_fresh = _within(self._autopilot, now_ns, timeout_ns)
        source: Source = "none"
        command = Command()
        if _within(self._operator, now_ns, self.cfg.operator_override_s * NS_PER_S):
            source = "operator"  # holds the autopilot off even once the person falls silent
            if operator_fresh and self._operator is not None:
                command = self._operator[0]
        elif autopilot_fresh and self._autopilot is not None:
            source, command = "autopilot", self._autopilot[0]
        live = operator_fresh or autopilot_fresh
        if self._live and not live:
            self.timeouts += 1
        if source == "operator" and self.source == "autopilot":
            self.overrides += 1
        self._live, self.source = live, source
        return command, source

    def take_applied(self) -> Applied | None:
        """The autopilot command applied for the first time by this step, once; None if the
        step applies no new autopilot command."""
        if self.source != "autopilot":
            return None
        applied, self._unapplied = self._unapplied, None
        return applied


def _within(held: tuple[Command, int] | None, now_ns: int, span_ns: float) -> bool:
    """True if `held` arrived less than `span_ns` before `now_ns`."""
    return held is not None and now_ns - held[1] < span_ns
