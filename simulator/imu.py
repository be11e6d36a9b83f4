"""IMU from the vessel dynamics: specific force, angular rate and orientation at the physics rate.

The accelerometer measures specific force (acceleration minus gravity), so at rest it reads
+g on its z axis, as ROS expects (REP 145). A mount away from the yaw axis adds the lever-arm
terms omega_dot x p + omega x (omega x p). Noise is a constant bias drawn once from the seed
plus white noise per sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from schemas.catalogue import TOPICS
from schemas.values import Message
from simulator.config import ImuConfig, SimConfig
from simulator.dynamics import StepResult
from simulator.frames import mount_rotation, quaternion_from_matrix, rotation_z
from simulator.messages import diagonal_covariance, header, quaternion, vector3
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, SensorFrame


@dataclass(frozen=True)
class ImuReading:
    """orientation_xyzw : sensor->map quaternion; angular_velocity_radps, linear_acceleration_mps2
    : (3,) float64 in the sensor frame."""

    orientation_xyzw: tuple[float, float, float, float]
    angular_velocity_radps: np.ndarray
    linear_acceleration_mps2: np.ndarray


class Imu:
    def __init__(self, cfg: ImuConfig | None = None, *, seed: int = 0) -> None:
        self.cfg = cfg or ImuConfig()
        self._rng = np.random.default_rng(seed)
        self._gyro_bias = self._rng.normal(0.0, self.cfg.gyro_bias_std_radps, 3)
        self._accel_bias = self._rng.normal(0.0, self.cfg.accel_bias_std_mps2, 3)
        self._mount_rotation = mount_rotation(self.cfg.mount)  # sensor -> base_link
        self._lever_m = np.array([self.cfg.mount.x_m, self.cfg.mount.y_m, self.cfg.mount.z_m])

    def measure(self, step: StepResult) -> ImuReading:
        """The reading after physics step `step`."""
        cfg, state = self.cfg, step.state
        r, r_dot = state.r_radps, step.yaw_accel_radps2
        px, py, _ = self._lever_m
        lever = np.array([-r_dot * py - r * r * px, r_dot * px - r * r * py, 0.0])
        accel_base = np.array([*step.accel_body_mps2, 0.0]) + lever
        specific_force = accel_base + np.array([0.0, 0.0, cfg.gravity_mps2])
        to_sensor = self._mount_rotation.T
        accel = to_sensor @ specific_force + self._accel_bias
        gyro = to_sensor @ np.array([0.0, 0.0, r]) + self._gyro_bias
        accel += self._rng.normal(0.0, cfg.accel_noise_std_mps2, 3)
        gyro += self._rng.normal(0.0, cfg.gyro_noise_std_radps, 3)
        yaw = state.yaw_rad + self._rng.normal(0.0, cfg.orientation_noise_std_rad)
        orientation = quaternion_from_matrix(rotation_z(yaw) @ self._mount_rotation)
        return ImuReading(orientation, gyro, accel)

    def message(self, reading: ImuReading, stamp_ns: int) -> Message:
        """sensor_msgs/msg/Imu, covariances from the configured white-noise levels."""
        cfg = self.cfg
        return {
            "header": header(stamp_ns, cfg.frame_id),
            "orientation": quaternion(reading.orientation_xyzw),
            "orientation_covariance": diagonal_covariance([cfg.orientation_noise_std_rad**2] * 3),
            "angular_velocity": vector3(reading.angular_velocity_radps),
            "angular_velocity_covariance": diagonal_covariance([cfg.gyro_noise_std_radps**2] * 3),
            "linear_acceleration": vector3(reading.linear_acceleration_mps2),
            "linear_acceleration_covariance": diagonal_covariance(
                [cfg.accel_noise_std_mps2**2] * 3
            ),
        }


class ImuSensor:
    """The simulator's IMU (simulator.sensor): a reading of every physics step."""

    topic = TOPICS["imu"]
    schedule: Schedule = "physics"

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self.imu = Imu(cfg.imu, seed=cfg.seed + 3)
        self.frame = SensorFrame(cfg.imu.frame_id, cfg.imu.mount)

    def generate(self, capture: Capture) -> Generated:
        return Generated(self.imu.message(self.imu.measure(capture.step), capture.stamp_ns))

    def close(self) -> None:
        """Nothing to release."""
