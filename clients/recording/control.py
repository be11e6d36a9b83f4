"""Playback control of ``riverbridge play``: its clock, and the service and state it offers.

`PlaybackClock` is pure: the recording's log time as a function of the event loop's clock,
under play, pause, speed and seek. The player offers it to everyone on the bridge:

- ``/riverbridge/playback/control`` (``riverbridge_msgs/srv/PlaybackControl``): play or
  pause, a speed, optionally a seek (a log time of the recording); answered with the state
  after it. This is what the bridge's Foxglove side calls for a client's
  ``PlaybackControlRequest`` (``bridge/foxglove/session.py``); any rosbridge client may call it.
- ``/riverbridge/playback/state`` (``riverbridge_msgs/msg/PlaybackState``), every
  ``STATE_PERIOD_S`` and after each change: status, current log time, speed and the
  recording's window, from which the bridge sends Foxglove clients their time.
"""

from __future__ import annotations

from dataclasses import dataclass

NS_PER_S = 1_000_000_000
CONTROL_SERVICE = "/riverbridge/playback/control"
CONTROL_TYPE = "riverbridge_msgs/srv/PlaybackControl"
STATE_TOPIC = "/riverbridge/playback/state"
STATE_TYPE = "riverbridge_msgs/msg/PlaybackState"
STATE_PERIOD_S = 0.1  # Foxglove's time display moves smoothly at 10 Hz
PLAYING, PAUSED, BUFFERING, ENDED = 0, 1, 2, 3  # PlaybackState.msg's constants


@dataclass
class PlaybackClock:
    """Log time (ns) against loop time (s): `log_ns` at `anchor_s`, moving at `speed` while
    `playing`. `anchor_wall_ns` is the wall clock at the anchor (for shifted stamps)."""

    speed: float
    log_ns: int
    anchor_s: float
    anchor_wall_ns: int
    playing: bool = True
    held: bool = False  # after a seek, until the player has read ahead from there

    def position_ns(self, now_s: float) -> int:
        if not self.playing or self.held:
            return self.log_ns
        return self.log_ns + round((now_s - self.anchor_s) * self.speed * NS_PER_S)

    def delay_s(self, log_ns: int, now_s: float) -> float | None:
        """Seconds until `log_ns` is due (<= 0: now); None while paused or held."""
        if not self.playing or self.held:
            return None
        return (log_ns - self.position_ns(now_s)) / NS_PER_S / self.speed

    def rebase(self, log_ns: int, now_s: float, wall_ns: int) -> None:
        """Stand at `log_ns` now and run from there (the start of a pass)."""
        self.log_ns, self.anchor_s, self.anchor_wall_ns = log_ns, now_s, wall_ns
        self.held = False

    def hold(self, log_ns: int, now_s: float, wall_ns: int) -> None:
        """Stand at `log_ns` until the next `rebase` (a seek: time stays at the target while
        the player reads ahead from there)."""
        self.rebase(log_ns, now_s, wall_ns)
        self.held = True

    def _hold(self, now_s: float, wall_ns: int) -> None:
        self.log_ns = self.position_ns(now_s)
        self.anchor_s, self.anchor_wall_ns = now_s, wall_ns

    def play(self, now_s: float, wall_ns: int) -> None:
        self._hold(now_s, wall_ns)
        self.playing = True

    def pause(self, now_s: float, wall_ns: int) -> None:
        self._hold(now_s, wall_ns)
        self.playing = False

    def set_speed(self, speed: float, now_s: float, wall_ns: int) -> None:
        if speed > 0 and speed != self.speed:
            self._hold(now_s, wall_ns)
            self.speed = speed

    def shifted(self, stamp_ns: int) -> int:
        """``--stamps shift``: a stamp on today's clock, as far from now as it was recorded
        from the message's log time (scaled by the speed)."""
        return self.anchor_wall_ns + round((stamp_ns - self.log_ns) / self.speed)


def stamp(ns: int) -> dict[str, int]:
    """ns as a ``builtin_interfaces/Time``."""
    sec, nanosec = divmod(ns, NS_PER_S)
    return {"sec": sec, "nanosec": nanosec}


def stamp_ns(value: object) -> int:
    """A ``builtin_interfaces/Time`` (dict) in ns; 0 when it is not one."""
    if not isinstance(value, dict):
        return 0
    return int(value.get("sec", 0)) * NS_PER_S + int(value.get("nanosec", 0))
