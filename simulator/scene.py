"""The static scene: one Embree BVH over every triangle, with per-triangle materials.

`build_scene` makes the default thesis scene (procedural valley, props, water surface) or loads
real terrain; `Scene` accepts any list of `MeshPart`s, which is how tests build known geometry.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from simulator import materials
from simulator.config import SceneConfig
from simulator.frames import Pose2D
from simulator.objects import WATER, SceneObjects
from simulator.props import MeshPart, landing_stages, trees_and_houses, vessels_on_course
from simulator.terrain import HeightField, heightfield_mesh, load_terrain
from simulator.valley import generate_valley
from simulator.water_obstacles import water_obstacles

log = logging.getLogger(__name__)

SHORE_BAND_M = 1.5  # terrain up to this height above the water is drawn as shore


class Scene:
    """All triangles of the world in one Embree scene.

    vertices : (v, 3) float32, map frame, metres
    faces : (f, 3) int32
    radar_reflectance : (f,) float32, thesis eq. 3.5.3 `ref_i`
    lidar_reflectivity : (f,) float32, 0..1 (0 = no LIDAR return)
    colour_rgb : (f, 3) uint8
    face_normals : (f, 3) float32, unit
    face_source : (f,) int32, the object id (>= 0) of each face, or LAND / WATER
    objects : the objects those ids name (simulator.objects), the ground truth
    The arrays are read-only; `embree` is safe to query from several threads at once.
    """

    def __init__(
        self,
        parts: Sequence[MeshPart],
        *,
        water_level_m: float = 0.0,
        start_pose: Pose2D | None = None,
        terrain: HeightField | None = None,
        objects: SceneObjects | None = None,
    ) -> None:
        if not parts:
            raise ValueError("a scene needs at least one mesh part")
        counts = [len(p.vertices) for p in parts]
        offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        self.vertices = np.concatenate([p.vertices for p in parts]).astype(np.float32)
        self.faces = np.concatenate(
            [np.asarray(p.faces, dtype=np.int64) + o for p, o in zip(parts, offsets, strict=True)]
        ).astype(np.int32)
        per_face = [len(p.faces) for p in parts]
        self.radar_reflectance = np.repeat(
            np.array([p.material.radar_reflectance for p in parts], np.float32), per_face
        )
        self.lidar_reflectivity = np.repeat(
            np.array([p.material.lidar_reflectivity for p in parts], np.float32), per_face
        )
        self.colour_rgb = np.repeat(
            np.array([p.material.colour_rgb for p in parts], np.uint8), per_face, axis=0
        )
        self.face_normals = _unit_normals(self.vertices, self.faces)
        self.face_source = np.concatenate(
            [np.broadcast_to(np.asarray(p.source, np.int32), len(p.faces)) for p in parts]
        )
        self.objects = objects or SceneObjects.empty()
        self.water_level_m = float(water_level_m)
        self.start_pose = start_pose or Pose2D(0.0, 0.0, 0.0)
        self.terrain = terrain
        for array in (
            self.vertices,
            self.faces,
            self.radar_reflectance,
            self.lidar_reflectivity,
            self.colour_rgb,
            self.face_normals,
            self.face_source,
        ):
            array.setflags(write=False)
        self.embree = rtcore_scene.EmbreeScene()
        TriangleMesh(self.embree, self.vertices, self.faces)

    @property
    def triangle_count(self) -> int:
        return len(self.faces)


def _unit_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(f, 3) float32 unit normals by the right-hand rule; degenerate faces get +z."""
    v0, v1, v2 = (vertices[faces[:, k]].astype(np.float64) for k in range(3))
    normals = np.cross(v1 - v0, v2 - v0)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 0, normals / np.where(length > 0, length, 1.0), [0.0, 0.0, 1.0])
    return normals.astype(np.float32)


def terrain_parts(field: HeightField, water_level_m: float) -> list[MeshPart]:
    """The terrain mesh split by height into riverbed, shore and grass parts, plus the water."""
    vertices, faces = heightfield_mesh(field)
    mean_z = vertices[faces, 2].mean(axis=1)
    bands = [
        (mean_z < water_level_m, materials.RIVERBED),
        ((mean_z >= water_level_m) & (mean_z < water_level_m + SHORE_BAND_M), materials.SHORE),
        (mean_z >= water_level_m + SHORE_BAND_M, materials.GRASS),
    ]
    parts = [MeshPart(vertices, faces[mask], material) for mask, material in bands if mask.any()]
    x0, y0 = field.origin_x_m, field.origin_y_m
    x1, y1 = x0 + field.extent_m[0], y0 + field.extent_m[1]
    water = np.array(
        [
            [x0, y0, water_level_m],
            [x1, y0, water_level_m],
            [x1, y1, water_level_m],
            [x0, y1, water_level_m],
        ]
    )
    parts.append(MeshPart(water, np.array([[0, 1, 2], [0, 2, 3]]), materials.WATER, WATER))
    return parts


def deepest_water_pose(field: HeightField, water_level_m: float) -> Pose2D:
    """A start pose on the water cell farthest from any shore (distance transform), yaw 0."""
    wet = (field.heights_m < water_level_m - 1.0).astype(np.uint8)
    if not wet.any():
        raise ValueError("terrain has no water deeper than 1 m below the water level")
    distance = cv2.distanceTransform(wet, cv2.DIST_L2, 5)
    i, j = np.unravel_index(int(np.argmax(distance)), distance.shape)
    x_m = field.origin_x_m + j * field.spacing_m
    return Pose2D(x_m, field.origin_y_m + i * field.spacing_m, 0.0)


def build_scene(cfg: SceneConfig | None = None, *, seed: int = 7) -> Scene:
    """The default thesis scene (or a loaded terrain) as one Embree scene.

    The same `cfg` and `seed` always give the same triangles.
    """
    cfg = cfg or SceneConfig()
    rng = np.random.default_rng(seed)
    if cfg.terrain_source == "procedural":
        field, course = generate_valley(cfg, rng)
        water_level_m = course.water_level_m
        y_start = -0.3 * cfg.size_m
        start = Pose2D(
            float(course.centre_x_m(y_start)), y_start, float(course.heading_rad(y_start))
        )
    else:
        raw = load_terrain(Path(cfg.terrain_source), cfg.heightmap_spacing_m, cfg.heightmap_range_m)
        field = raw.centred().resampled(cfg.terrain_cells)
        water_level_m = (
            float(field.heights_m.min()) + 1.0 if cfg.water_level_m is None else cfg.water_level_m
        )
        course, start = None, deepest_water_pose(field, water_level_m)
    parts = terrain_parts(field, water_level_m)
    objects = SceneObjects.empty()
    if course is not None:
        stages = landing_stages(cfg, course, rng)
        rest = trees_and_houses(cfg, course, field, rng, first_id=len(stages.objects))
        afloat = water_obstacles(
            cfg, course, start, first_id=len(stages.objects) + len(rest.objects)
        )
        first = len(stages.objects) + len(rest.objects) + len(afloat.objects)
        anchored = vessels_on_course(cfg, course, start.y_m, first_id=first)
        parts += stages.parts + rest.parts + afloat.parts + anchored.parts
        objects = (
            stages.objects.concat(rest.objects).concat(afloat.objects).concat(anchored.objects)
        )
    elif cfg.props_on_loaded_terrain:
        log.warning("props need the procedural river course; none placed on loaded terrain")
    scene = Scene(
        parts, water_level_m=water_level_m, start_pose=start, terrain=field, objects=objects
    )
    log.info(
        "scene: %d triangles, water level %.2f m, start %s",
        scene.triangle_count,
        water_level_m,
        start,
    )
    return scene
