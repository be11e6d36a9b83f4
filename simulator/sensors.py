"""The sensors the simulator has: the list the node loops over (simulator.sensor).

Each entry is a class that takes ``(SimConfig, Scene)`` and satisfies `Sensor`. Physics
sensors publish in this order after every step; worker sensors are staggered over their
period in this order. The vessel's state (odometry, the map -> base_link transform) comes
here too, as physics-rate sensors with no frame of their own.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from schemas.catalogue import TOPICS
from simulator.camera import CameraSensor
from simulator.config import SimConfig
from simulator.frames import mount_rotation, quaternion_from_matrix
from simulator.gnss import GnssSensor
from simulator.imu import ImuSensor
from simulator.lidar import LidarSensor
from simulator.messages import BASE_FRAME, odometry, tf_message, transform_stamped, vessel_tf
from simulator.radar import RadarSensor
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, Sensor


class OdometrySensor:
    """The vessel's true pose (map) and velocity (base_link) after every physics step."""

    topic = TOPICS["odom"]
    schedule: Schedule = "physics"
    frame = None

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._water_level_m = scene.water_level_m

    def generate(self, capture: Capture) -> Generated:
        state = capture.step.state
        return Generated(
            odometry(
                state.pose,
                self._water_level_m,
                (state.u_mps, state.v_mps),
                state.r_radps,
                capture.stamp_ns,
            )
        )

    def close(self) -> None:
        """Nothing to release."""


class TfSensor:
    """The transform map -> base_link after every physics step."""

    topic = TOPICS["tf"]
    schedule: Schedule = "physics"
    frame = None

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._water_level_m = scene.water_level_m

    def generate(self, capture: Capture) -> Generated:
        return Generated(vessel_tf(capture.pose, self._water_level_m, capture.stamp_ns))

    def close(self) -> None:
        """Nothing to release."""


SensorFactory = Callable[[SimConfig, Scene], Sensor]
SENSORS: tuple[SensorFactory, ...] = (
    LidarSensor,
    RadarSensor,
    CameraSensor,
    ImuSensor,
    GnssSensor,
    OdometrySensor,
    TfSensor,
)


def build_sensors(
    cfg: SimConfig, scene: Scene, factories: Sequence[SensorFactory] = SENSORS
) -> list[Sensor]:
    """One sensor of each factory, in order."""
    return [factory(cfg, scene) for factory in factories]


def static_transforms(sensors: Sequence[Sensor], stamp_ns: int) -> dict[str, Any]:
    """TFMessage base_link -> the frame of every sensor that has one, from its mount."""
    transforms = []
    for sensor in sensors:
        if sensor.frame is None:
            continue
        frame = sensor.frame
        rotation = mount_rotation(frame.mount)
        if frame.extra is not None:
            rotation = rotation @ frame.extra
        mount = frame.mount
        transforms.append(
            transform_stamped(
                stamp_ns,
                BASE_FRAME,
                frame.frame_id,
                (mount.x_m, mount.y_m, mount.z_m),
                quaternion_from_matrix(rotation),
            )
        )
    return tf_message(transforms)
