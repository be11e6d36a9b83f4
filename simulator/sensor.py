"""What one sensor is to the simulator node: a catalogue topic, a schedule and `generate`.

A sensor publishes one topic of ``schemas.catalogue`` (its name, type and role, and the
configuration key of its rate). `generate` makes the topic's message from one `Capture`: the
vessel after the latest physics step and the capture time; it never reads a clock and does no
I/O. Where and how often the node calls it follows from `schedule`:

* ``"physics"``: after every physics step, on the event loop, stamped at that step's time; a
  late physics tick publishes every step it catches up on (IMU, odometry, tf: ~0.1 ms each).
* ``"timer"``: on a fixed schedule of its own at its configured rate, on the event loop (GNSS).
* ``"worker"``: on a fixed schedule of its own, on a worker thread of its own at background
  priority, staggered over the period against the other worker sensors; a tick that falls a
  whole period behind is skipped, never queued; ground truth it returns goes out shortly after
  its message (LIDAR, radar, camera: ray casting, which releases the GIL).

Adding a sensor: see simulator/README.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
from pydantic import BaseModel

from schemas.catalogue import Topic
from simulator.config import MountConfig
from simulator.dynamics import Pose2D, StepResult

Schedule = Literal["physics", "timer", "worker"]
SCHEDULES: tuple[Schedule, ...] = ("physics", "timer", "worker")


@dataclass(frozen=True)
class Capture:
    """What a sensor sees: the vessel after the latest physics step, at ``stamp_ns`` (wall
    clock, the message's ``header.stamp``)."""

    step: StepResult
    stamp_ns: int

    @property
    def pose(self) -> Pose2D:
        return self.step.state.pose


@dataclass(frozen=True)
class Generated:
    """A sensor's message, and ``(topic, message)`` pairs of ground truth that came with it."""

    msg: dict[str, Any]
    truth: tuple[tuple[str, dict[str, Any]], ...] = ()


@dataclass(frozen=True)
class SensorFrame:
    """Where a sensor's ``frame_id`` sits on the vessel, for /tf_static; ``extra`` (3, 3)
    turns the mount's frame into the message's (the camera's optical frame)."""

    frame_id: str
    mount: MountConfig
    extra: np.ndarray | None = None


class Sensor(Protocol):
    """One source of messages on the simulator's schedules (see the module docstring)."""

    @property
    def topic(self) -> Topic:
        """Its schemas.catalogue entry."""
        ...

    @property
    def schedule(self) -> Schedule: ...

    @property
    def frame(self) -> SensorFrame | None:
        """Where it sits on the vessel; None: no frame of its own (odometry, tf)."""
        ...

    def generate(self, capture: Capture) -> Generated:
        """The message of ``capture`` (a worker sensor runs this on its own thread)."""
        ...

    def close(self) -> None:
        """Release threads and buffers; called once, after the last `generate`."""
        ...


def config_value(config: BaseModel, key: str) -> Any:
    """The value of a dotted configuration ``key`` (``"lidar.rate_hz"``) in ``config``;
    AttributeError naming the key when it does not exist."""
    value: Any = config
    for part in key.split("."):
        if not isinstance(value, BaseModel) or part not in type(value).model_fields:
            raise AttributeError(f"configuration has no {key!r}")
        value = getattr(value, part)
    return value
