"""RADAR (thesis 3.5.2, eq. 3.5.1-3.5.3, table 4.1): beams of rays summed into polar cells.

Each beam is `rays_vertical` x `rays_horizontal` rays spread over its elevation and azimuth
width. Every hit is projected onto the horizontal plane (the height is omitted, as in the
thesis), binned into (beam, range cell) and contributes its object's reflectance `ref_i`:
r_cell = sum_i ref_i (eq. 3.5.3). The binning is one `np.bincount`. For the ground truth a
sweep can also say, per cell, which source (an object, land, water) gave most of its
reflectance.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from schemas.catalogue import TOPICS
from schemas.values import Message
from simulator.config import RadarConfig, SimConfig
from simulator.frames import Pose2D, rotate_rows, sensor_pose_in_map
from simulator.messages import header
from simulator.objects import LAND, NO_RETURN, WATER
from simulator.raycast import RayCaster, fill_origins
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, SensorFrame
from simulator.truth import radar_truth


class RadarSweep(NamedTuple):
    """image : (num_beams, num_cells) float32 reflectance; cell_source : (num_beams,
    num_cells) int32, the source of most of each cell's reflectance (object id, LAND, WATER,
    or NO_RETURN where no ray landed; clutter is no source); object_rays : (k,) int64, rays
    of the sweep that landed in a cell from each of the scene's k objects."""

    image: np.ndarray
    cell_source: np.ndarray
    object_rays: np.ndarray


class RadarGeometry:
    """Ray table of one sweep, fixed by the configuration.

    directions_sensor : (num_beams * rays_per_beam, 3) float32, beam-major
    beam_index : (same,) int64, the beam each ray belongs to
    cos_elevation : (same,) float32, turns slant range into horizontal range
    """

    def __init__(self, cfg: RadarConfig) -> None:
        self.num_beams = round(360.0 / cfg.beam_width_azimuth_deg)
        self.azimuth_step_rad = 2 * np.pi / self.num_beams
        self.num_cells = int(np.ceil((cfg.range_max_m - cfg.range_min_m) / cfg.range_step_m))
        # Rays sit at the centres of equal sub-intervals of the beam's width.
        az_offsets = (np.arange(cfg.rays_horizontal) + 0.5) / cfg.rays_horizontal - 0.5
        el_offsets = (np.arange(cfg.rays_vertical) + 0.5) / cfg.rays_vertical - 0.5
        beam_az = np.arange(self.num_beams) * self.azimuth_step_rad
        az_width = np.radians(cfg.beam_width_azimuth_deg)
        az = beam_az[:, None, None] + az_width * az_offsets[None, None]
        el = np.radians(cfg.beam_width_elevation_deg) * el_offsets[None, :, None]
        az, el = np.broadcast_arrays(az, el)
        directions = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], -1)
        self.directions_sensor = np.ascontiguousarray(directions.reshape(-1, 3), np.float32)
        rays_per_beam = cfg.rays_vertical * cfg.rays_horizontal
        self.beam_index = np.repeat(np.arange(self.num_beams), rays_per_beam)
        self.cos_elevation = np.cos(el).reshape(-1).astype(np.float32)


class Radar:
    """A rotating radar producing one polar reflectance image per sweep.

    seed : seeds the Rayleigh clutter (`cfg.clutter_scale`).
    """

    def __init__(self, cfg: RadarConfig | None = None, *, threads: int = 1, seed: int = 0) -> None:
        self.cfg = cfg or RadarConfig()
        self.geometry = RadarGeometry(self.cfg)
        n = len(self.geometry.directions_sensor)
        self._directions_map = np.empty((n, 3), np.float32)
        self._origins = np.empty((n, 3), np.float32)
        self._caster = RayCaster(threads)
        self._rng = np.random.default_rng(seed)

    def close(self) -> None:
        self._caster.close()

    def sweep(self, scene: Scene, pose: Pose2D) -> np.ndarray:
        """One full turn; returns reflectance : (num_beams, num_cells) float32."""
        flat, faces = self._cast(scene, pose)
        return self._image(scene, flat, faces)

    def sweep_with_sources(self, scene: Scene, pose: Pose2D) -> RadarSweep:
        """`sweep`, plus the dominant source of every cell (for the ground truth)."""
        flat, faces = self._cast(scene, pose)
        cell_source, object_rays = self._sources(scene, flat, faces)
        return RadarSweep(self._image(scene, flat, faces), cell_source, object_rays)

    def _cast(self, scene: Scene, pose: Pose2D) -> tuple[np.ndarray, np.ndarray]:
        """Rays that landed in a cell: flat cell index (k,) int64 and hit face (k,) int32."""
        cfg, geo = self.cfg, self.geometry
        origin, rotation = sensor_pose_in_map(pose, cfg.mount, scene.water_level_m)
        rotate_rows(geo.directions_sensor, rotation, self._directions_map)
        fill_origins(self._origins, origin)
        range_m, prim = self._caster.cast(
            scene,
            self._origins,
            self._directions_map,
            cfg.range_max_m / float(geo.cos_elevation.min()),
        )
        horizontal_m = range_m * geo.cos_elevation  # eq. 3.5.1 uses the 2-D polar position
        cell = np.floor((horizontal_m - cfg.range_min_m) / cfg.range_step_m)
        valid = (prim >= 0) & (cell >= 0) & (cell < geo.num_cells)
        flat = geo.beam_index[valid] * geo.num_cells + cell[valid].astype(np.int64)
        return flat, prim[valid]

    def _image(self, scene: Scene, flat: np.ndarray, faces: np.ndarray) -> np.ndarray:
        cfg, geo = self.cfg, self.geometry
        image = np.bincount(
            flat, weights=scene.radar_reflectance[faces], minlength=geo.num_beams * geo.num_cells
        ).astype(np.float32)
        if cfg.clutter_scale > 0:
            image += self._rng.rayleigh(cfg.clutter_scale, image.shape).astype(np.float32)
        return image.reshape(geo.num_beams, geo.num_cells)

    def _sources(
        self, scene: Scene, flat: np.ndarray, faces: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per cell the source with the largest summed reflectance, and the rays per object.

        Sources are numbered objects 0..k-1, then land, then water; the (cell, source) pairs
        of the sweep's few thousand rays are summed with one unique + bincount, and each
        cell keeps its largest pair (a lexsort), so no (cells x sources) table is built.
        """
        geo = self.geometry
        k = len(scene.objects)
        source = scene.face_source[faces].astype(np.int64)
        object_rays = np.bincount(source[source >= 0], minlength=k)[:k]
        column = np.where(source >= 0, source, np.where(source == LAND, k, k + 1))
        pairs, inverse = np.unique(flat * (k + 2) + column, return_inverse=True)
        sums = np.bincount(inverse.reshape(-1), weights=scene.radar_reflectance[faces])
        cell, column = np.divmod(pairs, k + 2)
        order = np.lexsort((-sums, cell))  # by cell, the largest sum first
        first = order[np.r_[True, cell[order][1:] != cell[order][:-1]]] if len(order) else order
        first = first[sums[first] > 0.0]
        named = np.full(geo.num_beams * geo.num_cells, NO_RETURN, np.int32)
        best = column[first]
        named[cell[first]] = np.where(best < k, best, np.where(best == k, LAND, WATER))
        return named.reshape(geo.num_beams, geo.num_cells), object_rays

    def message(self, image: np.ndarray, stamp_ns: int) -> Message:
        """riverbridge_msgs/msg/RadarImage of a sweep, stamped with its capture time."""
        cfg, geo = self.cfg, self.geometry
        return {
            "header": header(stamp_ns, cfg.frame_id),
            # float32 fields carry float32-representable values so every encoding agrees.
            "azimuth_min_rad": 0.0,
            "azimuth_step_rad": _f32(geo.azimuth_step_rad),
            "beam_width_azimuth_rad": _f32(np.radians(cfg.beam_width_azimuth_deg)),
            "beam_width_elevation_rad": _f32(np.radians(cfg.beam_width_elevation_deg)),
            "range_min_m": _f32(cfg.range_min_m),
            "range_step_m": _f32(cfg.range_step_m),
            "num_beams": int(geo.num_beams),
            "num_cells": int(geo.num_cells),
            "reflectance": np.ascontiguousarray(image, np.float32).reshape(-1),
        }


class RadarSensor:
    """The simulator's radar (simulator.sensor): a sweep per tick on its worker thread, and
    with ``[ground_truth] enabled`` what filled each cell."""

    topic = TOPICS["radar"]
    schedule: Schedule = "worker"

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._cfg, self._scene = cfg, scene
        self.radar = Radar(cfg.radar, seed=cfg.seed + 2)
        self.frame = SensorFrame(cfg.radar.frame_id, cfg.radar.mount)

    def generate(self, capture: Capture) -> Generated:
        pose, stamp_ns = capture.pose, capture.stamp_ns
        if not self._cfg.ground_truth.enabled:
            return Generated(self.radar.message(self.radar.sweep(self._scene, pose), stamp_ns))
        sweep = self.radar.sweep_with_sources(self._scene, pose)
        truth = radar_truth(self._scene, self._cfg.radar, pose, sweep, stamp_ns)
        return Generated(
            self.radar.message(sweep.image, stamp_ns), ((TOPICS["radar_truth"].name, truth),)
        )

    def close(self) -> None:
        self.radar.close()


def _f32(value: float) -> float:
    """`value` rounded to float32, as a Python float."""
    return float(np.float32(value))
