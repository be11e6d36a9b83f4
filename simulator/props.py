"""Objects along the procedural river (thesis 3.5.1): landing stages, moored vessels, trees, houses.

Each kind is one template mesh instanced with numpy broadcasting (positions, yaws, scales), so
the number of objects never turns into a Python loop over vertices. Every instance is one
object of the ground truth (`simulator.objects`): its faces carry the object's id, and the
parts of one object (a pontoon and its gangway, a hull and its cabin) share it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from simulator import materials
from simulator.config import SceneConfig
from simulator.materials import Material
from simulator.objects import LAND, SceneObjects, object_boxes
from simulator.terrain import HeightField
from simulator.valley import BANK_WIDTH_M, RiverCourse


@dataclass(frozen=True)
class MeshPart:
    """A triangle soup of one material: vertices (n, 3) float, faces (m, 3) int.

    source : what a ray hitting a face has hit, for the ground truth: an object id >= 0 per
    face ((m,) int), or one of `simulator.objects.LAND` / `WATER` for the whole part.
    """

    vertices: np.ndarray
    faces: np.ndarray
    material: Material
    source: np.ndarray | int = LAND


@dataclass(frozen=True)
class Props:
    """Mesh parts of a group of objects and the objects themselves (ids first_id ..)."""

    parts: list[MeshPart]
    objects: SceneObjects


def instance(
    template: trimesh.Trimesh,
    positions: np.ndarray,
    yaws_rad: np.ndarray,
    scales: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Copies of `template`: scaled (k, 3), turned about z (k,), moved to positions (k, 3).

    Returns vertices (k * v, 3) and faces (k * f, 3) of all copies.
    """
    k = len(positions)
    base = np.asarray(template.vertices, dtype=np.float64)
    scaled = base[None] * (np.ones((k, 3)) if scales is None else np.asarray(scales))[:, None]
    c, s = np.cos(yaws_rad)[:, None], np.sin(yaws_rad)[:, None]
    x = c * scaled[..., 0] - s * scaled[..., 1]
    y = s * scaled[..., 0] + c * scaled[..., 1]
    moved = np.stack([x, y, scaled[..., 2]], axis=-1) + np.asarray(positions)[:, None]
    offsets = (np.arange(k) * len(base))[:, None, None]
    faces = np.asarray(template.faces)[None] + offsets
    return moved.reshape(-1, 3), faces.reshape(-1, 3)


def instanced_part(
    template: trimesh.Trimesh,
    material: Material,
    positions: np.ndarray,
    yaws: np.ndarray,
    scales: np.ndarray | None = None,
    first_id: int = 0,
) -> MeshPart:
    """`template` instanced at `positions`; instance i is object first_id + i."""
    vertices, faces = instance(template, positions, yaws, scales)
    per_instance = len(template.faces)
    ids = first_id + np.repeat(np.arange(len(positions)), per_instance)
    return MeshPart(vertices, faces, material, ids)


def objects_of(
    kind: str,
    parts: list[MeshPart],
    positions: np.ndarray,
    yaws: np.ndarray,
    first_id: int,
    *,
    on_water: bool,
) -> SceneObjects:
    """Oriented boxes of the objects first_id .. that `parts` build, `kind` for all."""
    vertices = np.concatenate([p.vertices for p in parts])
    ids = np.concatenate([_vertex_ids(p) for p in parts]) - first_id
    return object_boxes(kind, vertices, ids, positions, yaws, first_id, on_water=on_water)


def _vertex_ids(part: MeshPart) -> np.ndarray:
    """(n,) object id of every vertex of an instanced part (faces never span instances)."""
    ids = np.empty(len(part.vertices), np.int64)
    ids[np.asarray(part.faces).reshape(-1)] = np.repeat(np.asarray(part.source), 3)
    return ids


def box_mesh(extent_x: float, extent_y: float, extent_z: float, z_bottom: float) -> trimesh.Trimesh:
    """A box whose bottom face sits at `z_bottom` (local frame)."""
    box: trimesh.Trimesh = trimesh.creation.box(extents=(extent_x, extent_y, extent_z))
    box.apply_translation((0.0, 0.0, z_bottom + extent_z / 2))
    return box


def _roof(extent_x: float, extent_y: float, z_eaves: float, rise: float) -> trimesh.Trimesh:
    """A gable roof: a triangular prism whose ridge runs along x."""
    hx, hy = extent_x / 2, extent_y / 2
    vertices = [
        (-hx, -hy, z_eaves),
        (-hx, hy, z_eaves),
        (-hx, 0.0, z_eaves + rise),
        (hx, -hy, z_eaves),
        (hx, hy, z_eaves),
        (hx, 0.0, z_eaves + rise),
    ]
    faces = [(0, 2, 1), (3, 4, 5), (0, 3, 5), (0, 5, 2), (1, 2, 5), (1, 5, 4), (0, 1, 4), (0, 4, 3)]
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def _stage_sites(
    cfg: SceneConfig, course: RiverCourse, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (k, 3), yaws (k,) and bank side (k,) of the landing stages, spread along y."""
    k = cfg.landing_stages
    y = np.linspace(-0.35, 0.35, k) * cfg.size_m + rng.uniform(-40, 40, k)
    side = np.where(np.arange(k) % 2 == 0, 1.0, -1.0)  # alternate east and west bank
    x = course.centre_x_m(y) + side * (course.half_width_m - 5.0)
    yaw = course.heading_rad(y)
    return np.column_stack([x, y, np.full(k, course.water_level_m)]), yaw, side


def landing_stages(
    cfg: SceneConfig, course: RiverCourse, rng: np.random.Generator, first_id: int = 0
) -> Props:
    """Pontoons on the water with a gangway to the bank, plus moored vessels alongside."""
    positions, yaws, side = _stage_sites(cfg, course, rng)
    # Pontoon 20 m x 4 m floating with 0.5 m freeboard; gangway reaches 10 m up onto the bank.
    normal = np.column_stack([np.sin(yaws), -np.cos(yaws), np.zeros_like(yaws)])  # to the east
    gangway = positions + normal * side[:, None] * 8.0
    stages = [
        instanced_part(
            box_mesh(20.0, 4.0, 1.2, -0.7), materials.STEEL, positions, yaws, first_id=first_id
        ),
        instanced_part(
            box_mesh(1.5, 12.0, 0.3, 0.5), materials.WOOD, gangway, yaws, first_id=first_id
        ),
    ]
    objects = objects_of("landing_stage", stages, positions, yaws, first_id, on_water=True)
    parts = list(stages)
    n_vessels = min(cfg.moored_vessels, len(positions))
    if n_vessels:
        first_vessel = first_id + len(positions)
        hulls = positions[:n_vessels] - normal[:n_vessels] * side[:n_vessels, None] * 3.5
        vessel_yaws = yaws[:n_vessels]
        forward = np.column_stack([np.cos(vessel_yaws), np.sin(vessel_yaws), 0 * vessel_yaws])
        cabins = hulls + forward  # cabin 1 m forward of the hull centre
        vessels = [
            instanced_part(
                box_mesh(8.0, 2.6, 1.6, -0.6),
                materials.VESSEL,
                hulls,
                vessel_yaws,
                first_id=first_vessel,
            ),
            instanced_part(
                box_mesh(3.0, 2.0, 1.5, 1.0),
                materials.VESSEL,
                cabins,
                vessel_yaws,
                first_id=first_vessel,
            ),
        ]
        parts += vessels
        objects = objects.concat(
            objects_of("vessel", vessels, hulls, vessel_yaws, first_vessel, on_water=True)
        )
    return Props(parts, objects)


def _land_sites(
    course: RiverCourse,
    field: HeightField,
    rng: np.random.Generator,
    count: int,
    near_m: float,
    far_m: float,
) -> np.ndarray:
    """`count` points on land between `near_m` and `far_m` beyond the river banks."""
    y = rng.uniform(-0.45, 0.45, count) * (field.extent_m[1])
    offset = course.half_width_m + BANK_WIDTH_M + rng.uniform(near_m, far_m, count)
    x = course.centre_x_m(y) + np.where(rng.random(count) < 0.5, -1.0, 1.0) * offset
    return np.column_stack([x, y, field.height_at(x, y)])


def trees_and_houses(
    cfg: SceneConfig,
    course: RiverCourse,
    field: HeightField,
    rng: np.random.Generator,
    first_id: int = 0,
) -> Props:
    """Trees along the banks and houses a little further up the valley sides."""
    parts: list[MeshPart] = []
    objects = SceneObjects.empty()
    if cfg.trees:
        sites = _land_sites(course, field, rng, cfg.trees, -8.0, 120.0)
        scale = rng.uniform(0.7, 1.3, (cfg.trees, 1)) * np.ones((1, 3))
        yaws = rng.uniform(0, 2 * np.pi, cfg.trees)
        trunk = trimesh.creation.cylinder(radius=0.25, height=3.5, sections=6)
        trunk.apply_translation((0, 0, 1.5))  # sink 0.25 m into the ground on slopes
        crown = trimesh.creation.icosphere(subdivisions=1, radius=2.5)
        crown.apply_translation((0, 0, 5.0))
        trees = [
            instanced_part(trunk, materials.WOOD, sites, yaws, scale, first_id),
            instanced_part(crown, materials.FOLIAGE, sites, yaws, scale, first_id),
        ]
        parts += trees
        objects = objects.concat(objects_of("tree", trees, sites, yaws, first_id, on_water=False))
    if cfg.houses:
        first_house = first_id + len(objects)
        sites = _land_sites(course, field, rng, cfg.houses, 40.0, 300.0)
        sites[:, 2] -= 0.5  # foundations into the slope
        yaws = rng.uniform(0, 2 * np.pi, cfg.houses)
        houses = [
            instanced_part(
                box_mesh(10.0, 8.0, 6.5, 0.0), materials.BRICK, sites, yaws, first_id=first_house
            ),
            instanced_part(
                _roof(10.6, 8.6, 6.5, 3.0), materials.ROOF, sites, yaws, first_id=first_house
            ),
        ]
        parts += houses
        objects = objects.concat(
            objects_of("house", houses, sites, yaws, first_house, on_water=False)
        )
    return Props(parts, objects)


def vessels_on_course(
    cfg: SceneConfig, course: RiverCourse, start_y_m: float, first_id: int = 0
) -> Props:
    """Vessels at anchor on the river's centre line, `cfg.vessels_on_course_m` downstream of
    the start (a guidance scenario: docs/guidance.md). Distances are taken along y, which the
    gently meandering river follows to within a few per cent."""
    if not cfg.vessels_on_course_m:
        return Props([], SceneObjects.empty())
    y = start_y_m + np.asarray(cfg.vessels_on_course_m, dtype=np.float64)
    hulls = np.column_stack([course.centre_x_m(y), y, np.full(len(y), course.water_level_m)])
    yaws = course.heading_rad(y)
    forward = np.column_stack([np.cos(yaws), np.sin(yaws), np.zeros_like(yaws)])
    parts = [
        instanced_part(
            box_mesh(8.0, 2.6, 1.6, -0.6), materials.VESSEL, hulls, yaws, first_id=first_id
        ),
        instanced_part(
            box_mesh(3.0, 2.0, 1.5, 1.0), materials.VESSEL, hulls + forward, yaws, first_id=first_id
        ),
    ]
    return Props(parts, objects_of("vessel", parts, hulls, yaws, first_id, on_water=True))
