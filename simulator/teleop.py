"""Keyboard teleoperation as a pure state machine: key bytes in, a surge/yaw command out.

No terminal, clock or socket here (`simulator.teleop_cli` owns those), so every rule is
unit-testable. The command is held as integer step counts, so pressing up ten times and down
ten times returns exactly to zero (no float drift), and it is clipped to the actuator limits
of `VesselConfig`, the same limits the dynamics clip to.

Keys: up / w raise the surge force (down / s lower it, through zero to astern); left / a turn
to port (positive yaw moment: counter-clockwise, REP 103), right / d to starboard; space
zeroes both; q, Ctrl-C or Ctrl-D quit.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from pydantic import BaseModel, ConfigDict, Field

from schemas.values import Message
from simulator.config import VesselConfig


class Action(enum.Enum):
    SURGE_UP = "surge up"
    SURGE_DOWN = "surge down"
    YAW_LEFT = "yaw left"
    YAW_RIGHT = "yaw right"
    STOP = "stop"
    QUIT = "quit"


# Arrow keys arrive as ANSI escape sequences: CSI (normal cursor mode) or SS3 (application
# cursor mode, which some terminals switch to); both spellings map to the same action.
KEYS: dict[bytes, Action] = {
    b"\x1b[A": Action.SURGE_UP,
    b"\x1bOA": Action.SURGE_UP,
    b"\x1b[B": Action.SURGE_DOWN,
    b"\x1bOB": Action.SURGE_DOWN,
    b"\x1b[D": Action.YAW_LEFT,
    b"\x1bOD": Action.YAW_LEFT,
    b"\x1b[C": Action.YAW_RIGHT,
    b"\x1bOC": Action.YAW_RIGHT,
    b"w": Action.SURGE_UP,
    b"W": Action.SURGE_UP,
    b"s": Action.SURGE_DOWN,
    b"S": Action.SURGE_DOWN,
    b"a": Action.YAW_LEFT,
    b"A": Action.YAW_LEFT,
    b"d": Action.YAW_RIGHT,
    b"D": Action.YAW_RIGHT,
    b" ": Action.STOP,
    b"q": Action.QUIT,
    b"Q": Action.QUIT,
    b"\x03": Action.QUIT,  # Ctrl-C when the terminal does not turn it into SIGINT
    b"\x04": Action.QUIT,  # Ctrl-D
}
_PREFIXES = frozenset(seq[:k] for seq in KEYS for k in range(1, len(seq)))


class KeyDecoder:
    """Turns raw terminal bytes into actions; an escape sequence split across two reads is
    kept until it completes. Bytes of no known key are ignored."""

    def __init__(self) -> None:
        self._pending = b""

    def feed(self, data: bytes) -> list[Action]:
        buffer, actions = self._pending + data, []
        while buffer:
            length = next((n for n in (3, 1) if buffer[:n] in KEYS), 0)
            if length:
                actions.append(KEYS[buffer[:length]])
                buffer = buffer[length:]
            elif buffer in _PREFIXES:
                break  # the rest of an escape sequence is still on its way
            else:
                buffer = buffer[1:]  # an unknown key (or a lone ESC): skip one byte
        self._pending = buffer
        return actions


class TeleopScale(BaseModel):
    """Actuator limits and how many key presses reach them."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_surge_force_n: float = Field(default=VesselConfig().max_surge_force_n, gt=0)
    max_yaw_moment_nm: float = Field(default=VesselConfig().max_yaw_moment_nm, gt=0)
    # ten presses from zero to full: 400 N and 600 N m per press for the default vessel
    steps: int = Field(default=10, ge=1)

    @classmethod
    def of(cls, vessel: VesselConfig, steps: int = 10) -> TeleopScale:
        return cls(
            max_surge_force_n=vessel.max_surge_force_n,
            max_yaw_moment_nm=vessel.max_yaw_moment_nm,
            steps=steps,
        )

    @property
    def surge_step_n(self) -> float:
        return self.max_surge_force_n / self.steps

    @property
    def yaw_step_nm(self) -> float:
        return self.max_yaw_moment_nm / self.steps


@dataclass(frozen=True)
class TeleopCommand:
    """The demanded surge force and yaw moment, in key-press steps (within +- scale.steps)."""

    surge_steps: int = 0
    yaw_steps: int = 0

    def apply(self, action: Action, scale: TeleopScale) -> TeleopCommand:
        """The command after `action`; QUIT leaves it unchanged (quitting is the caller's)."""
        surge, yaw = self.surge_steps, self.yaw_steps
        match action:
            case Action.SURGE_UP:
                surge += 1
            case Action.SURGE_DOWN:
                surge -= 1
            case Action.YAW_LEFT:
                yaw += 1
            case Action.YAW_RIGHT:
                yaw -= 1
            case Action.STOP:
                surge = yaw = 0
        limit = scale.steps
        return TeleopCommand(max(-limit, min(limit, surge)), max(-limit, min(limit, yaw)))

    def surge_force_n(self, scale: TeleopScale) -> float:
        return self.surge_steps * scale.surge_step_n

    def yaw_moment_nm(self, scale: TeleopScale) -> float:
        return self.yaw_steps * scale.yaw_step_nm

    def wrench(self, scale: TeleopScale) -> Message:
        """Canonical geometry_msgs/msg/Wrench: force.x surge (N), torque.z yaw (N m)."""
        return {
            "force": {"x": self.surge_force_n(scale), "y": 0.0, "z": 0.0},
            "torque": {"x": 0.0, "y": 0.0, "z": self.yaw_moment_nm(scale)},
        }

    def status(self, scale: TeleopScale) -> str:
        """One status line, e.g. `surge +1200 N ( 30%)  yaw  -600 N m (-10%)`."""
        surge_pct = 100 * self.surge_steps / scale.steps
        yaw_pct = 100 * self.yaw_steps / scale.steps
        return (
            f"surge {self.surge_force_n(scale):+6.0f} N ({surge_pct:+4.0f}%)  "
            f"yaw {self.yaw_moment_nm(scale):+6.0f} N m ({yaw_pct:+4.0f}%)"
        )
