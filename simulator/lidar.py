"""LIDAR (thesis 3.5.2, table 4.3): a 360 deg x 60 deg grid of rays cast with Embree.

The ray directions are built once in the sensor frame; a scan rotates them by the pose with
one matmul into a reused buffer, casts them on the ray-casting threads, and keeps the hits as
(range * direction) in the sensor frame, so no point is ever touched by Python code. Which
water hits return follows `LidarConfig.water_model`; each point remembers what it hit (an
object id, LAND or WATER) for the ground truth.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import numpy as np

from schemas.catalogue import TOPICS
from schemas.pointcloud import LAYOUTS, pack_points
from schemas.values import Message
from simulator.config import LidarConfig, SimConfig
from simulator.frames import Pose2D, rotate_rows, sensor_pose_in_map
from simulator.objects import WATER
from simulator.raycast import RayCaster, fill_origins
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, SensorFrame
from simulator.truth import lidar_truth


class LidarScan(NamedTuple):
    """points : (n, 4) float32 (x, y, z sensor frame, intensity); source : (n,) int32, what
    each point hit (object id, or LAND / WATER; `simulator.objects`), empty unless asked."""

    points: np.ndarray
    source: np.ndarray


def lidar_directions(cfg: LidarConfig) -> np.ndarray:
    """(rows * cols, 3) float32 unit directions in the sensor frame, row-major (elevation, azimuth).

    Azimuth starts at -fov/2 (behind, for 360 deg) and increases counter-clockwise; elevations
    are cell centres spanning the vertical field of view symmetrically about the horizon.
    """
    cols = round(cfg.horizontal_fov_deg / cfg.horizontal_resolution_deg)
    rows = round(cfg.vertical_fov_deg / cfg.vertical_resolution_deg)
    azimuth = np.radians(
        -cfg.horizontal_fov_deg / 2 + (np.arange(cols) + 0.5) * cfg.horizontal_resolution_deg
    )
    elevation = np.radians(
        -cfg.vertical_fov_deg / 2 + (np.arange(rows) + 0.5) * cfg.vertical_resolution_deg
    )
    el, az = np.meshgrid(elevation, azimuth, indexing="ij")
    directions = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)
    return np.ascontiguousarray(directions.reshape(-1, 3), dtype=np.float32)


class Lidar:
    """A spinning LIDAR; `scan` returns the hits of one full revolution.

    threads : ray-casting threads (embreex releases the GIL, so 2 threads ~ halve a scan).
    seed : seeds the range noise (`cfg.range_noise_std_m`).
    """

    def __init__(self, cfg: LidarConfig | None = None, *, threads: int = 2, seed: int = 0) -> None:
        self.cfg = cfg or LidarConfig()
        self.directions_sensor = lidar_directions(self.cfg)
        self.directions_sensor.setflags(write=False)
        n = len(self.directions_sensor)
        self._directions_map = np.empty((n, 3), np.float32)
        self._origins = np.empty((n, 3), np.float32)
        self._caster = RayCaster(threads)
        self._rng = np.random.default_rng(seed)
        self._specular = self.cfg.water_model == "specular"
        self._cos_max_incidence = float(np.cos(np.radians(self.cfg.water_max_incidence_deg)))

    @property
    def ray_count(self) -> int:
        return len(self.directions_sensor)

    def close(self) -> None:
        self._caster.close()

    def scan(self, scene: Scene, pose: Pose2D) -> np.ndarray:
        """One revolution from the vessel at `pose`.

        returns points : (n, 4) float32 (x, y, z in the sensor frame, metres; intensity 0..1),
        hits only, ordered by ray; rays ending on no-return surfaces are dropped.
        """
        return self._scan(scene, pose, with_sources=False).points

    def scan_with_sources(self, scene: Scene, pose: Pose2D) -> LidarScan:
        """`scan`, plus what every point hit (for the ground truth; one more gather)."""
        return self._scan(scene, pose, with_sources=True)

    def _scan(self, scene: Scene, pose: Pose2D, with_sources: bool) -> LidarScan:
        origin, rotation = sensor_pose_in_map(pose, self.cfg.mount, scene.water_level_m)
        rotate_rows(self.directions_sensor, rotation, self._directions_map)
        fill_origins(self._origins, origin)
        chunks = self._caster.map_chunks(
            scene,
            self._origins,
            self._directions_map,
            self.cfg.range_max_m,
            partial(self._points, scene, with_sources),
        )
        if len(chunks) > 1:
            points = np.concatenate([c.points for c in chunks])
            source = np.concatenate([c.source for c in chunks])
        else:
            points, source = chunks[0]
        if self.cfg.range_noise_std_m > 0:  # drawn here, in ray order, so threads don't matter
            range_m = np.linalg.norm(points[:, :3], axis=1)
            noise_m = self._rng.normal(0.0, self.cfg.range_noise_std_m, len(points))
            points[:, :3] *= ((range_m + noise_m) / range_m)[:, None]
        return LidarScan(points, source)

    def _points(
        self, scene: Scene, with_sources: bool, chunk: slice, range_m: np.ndarray, prim: np.ndarray
    ) -> LidarScan:
        """The returning rays of one chunk (runs on a worker thread); sources only if asked."""
        hit = np.flatnonzero(prim >= 0)
        faces = np.take(prim, hit)
        intensity = np.take(scene.lidar_reflectivity, faces)
        ranges = np.take(range_m, hit)
        keep = (intensity > 0) & (ranges >= self.cfg.range_min_m)
        if self._specular:
            keep &= self._water_returns(scene, chunk, hit, faces)
        hit, intensity, ranges = hit[keep], intensity[keep], ranges[keep]
        points = np.empty((len(hit), 4), np.float32)
        directions = np.take(self.directions_sensor[chunk], hit, axis=0)
        np.multiply(directions, ranges[:, None], out=points[:, :3])
        points[:, 3] = intensity
        source = np.take(scene.face_source, faces[keep]) if with_sources else np.empty(0, np.int32)
        return LidarScan(points, source)

    def _water_returns(
        self, scene: Scene, chunk: slice, hit: np.ndarray, faces: np.ndarray
    ) -> np.ndarray:
        """Specular water: (k,) bool, False for water hits further than the maximum incidence
        from the surface normal (the beam is mirrored away), True for everything else."""
        water = np.flatnonzero(np.take(scene.face_source, faces) == WATER)
        keep = np.ones(len(hit), bool)
        if water.size:
            directions = np.take(self._directions_map[chunk], hit[water], axis=0)
            normals = np.take(scene.face_normals, faces[water], axis=0)
            cos_incidence = np.abs(np.einsum("ij,ij->i", directions, normals))
            keep[water] = cos_incidence >= self._cos_max_incidence
        return keep

    def message(self, points: np.ndarray, stamp_ns: int) -> Message:
        """sensor_msgs/msg/PointCloud2 of a scan (`point_fields`), stamped with its capture
        time."""
        return pack_points(points, stamp_ns, self.cfg.frame_id, LAYOUTS[self.cfg.point_fields])


class LidarSensor:
    """The simulator's LIDAR (simulator.sensor): a scan per tick on its worker thread, and
    with ``[ground_truth] enabled`` what the scan saw."""

    topic = TOPICS["lidar"]
    schedule: Schedule = "worker"

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._cfg, self._scene = cfg, scene
        self.lidar = Lidar(cfg.lidar, threads=2, seed=cfg.seed + 1)
        self.frame = SensorFrame(cfg.lidar.frame_id, cfg.lidar.mount)

    def generate(self, capture: Capture) -> Generated:
        pose, stamp_ns = capture.pose, capture.stamp_ns
        if not self._cfg.ground_truth.enabled:
            return Generated(self.lidar.message(self.lidar.scan(self._scene, pose), stamp_ns))
        scan = self.lidar.scan_with_sources(self._scene, pose)
        truth = lidar_truth(self._scene, self._cfg.lidar, pose, scan.source, stamp_ns)
        return Generated(
            self.lidar.message(scan.points, stamp_ns), ((TOPICS["lidar_truth"].name, truth),)
        )

    def close(self) -> None:
        self.lidar.close()
