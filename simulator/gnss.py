"""GNSS receiver: the antenna position in the map frame as WGS84 latitude/longitude.

The map frame is a local UTM grid: map (0, 0) is (`origin_easting_m`, `origin_northing_m`) of
`utm_zone` north, map x is UTM easting, map y northing (grid convergence, under 1.5 deg here,
is part of that definition). Map z = 0 (the water level) has ellipsoidal height
`water_level_altitude_m`.
"""

from __future__ import annotations

import numpy as np

from schemas.catalogue import TOPICS
from schemas.values import Message
from simulator.config import GnssConfig, SimConfig
from simulator.frames import Pose2D, sensor_pose_in_map
from simulator.messages import diagonal_covariance, header
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, SensorFrame
from simulator.utm import utm_to_latlon

NAVSAT_STATUS_FIX = 0  # sensor_msgs/msg/NavSatStatus.STATUS_FIX
NAVSAT_SERVICE_GPS = 1  # sensor_msgs/msg/NavSatStatus.SERVICE_GPS
COVARIANCE_TYPE_DIAGONAL_KNOWN = 2  # sensor_msgs/msg/NavSatFix


class Gnss:
    def __init__(self, cfg: GnssConfig | None = None, *, seed: int = 0) -> None:
        self.cfg = cfg or GnssConfig()
        self._rng = np.random.default_rng(seed)

    def fix(self, pose: Pose2D, water_level_m: float = 0.0) -> tuple[float, float, float]:
        """(latitude deg, longitude deg, altitude m) of the antenna, with configured noise."""
        cfg = self.cfg
        antenna, _ = sensor_pose_in_map(pose, cfg.mount, water_level_m)
        noise = self._rng.normal(
            0.0, [cfg.horizontal_noise_std_m, cfg.horizontal_noise_std_m, cfg.vertical_noise_std_m]
        )
        x_m, y_m, z_m = antenna + noise
        lat, lon = utm_to_latlon(
            cfg.origin_easting_m + x_m, cfg.origin_northing_m + y_m, cfg.utm_zone
        )
        return float(lat), float(lon), float(cfg.water_level_altitude_m + z_m - water_level_m)

    def message(self, fix: tuple[float, float, float], stamp_ns: int) -> Message:
        """sensor_msgs/msg/NavSatFix with a diagonal covariance from the configured noise."""
        cfg = self.cfg
        horizontal, vertical = cfg.horizontal_noise_std_m**2, cfg.vertical_noise_std_m**2
        return {
            "header": header(stamp_ns, cfg.frame_id),
            "status": {"status": NAVSAT_STATUS_FIX, "service": NAVSAT_SERVICE_GPS},
            "latitude": fix[0],
            "longitude": fix[1],
            "altitude": fix[2],
            "position_covariance": diagonal_covariance([horizontal, horizontal, vertical]),
            "position_covariance_type": COVARIANCE_TYPE_DIAGONAL_KNOWN,
        }


class GnssSensor:
    """The simulator's GNSS receiver (simulator.sensor): a fix per tick, on the event loop."""

    topic = TOPICS["gnss"]
    schedule: Schedule = "timer"

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._water_level_m = scene.water_level_m
        self.gnss = Gnss(cfg.gnss, seed=cfg.seed + 4)
        self.frame = SensorFrame(cfg.gnss.frame_id, cfg.gnss.mount)

    def generate(self, capture: Capture) -> Generated:
        fix = self.gnss.fix(capture.pose, self._water_level_m)
        return Generated(self.gnss.message(fix, capture.stamp_ns))

    def close(self) -> None:
        """Nothing to release."""
