"""The scene's objects as ground truth: what a vessel, buoy, landing stage, tree or house is,
where, and whether it stands on the water (an obstacle for a vessel) or on the bank.

Every prop instance is one object with an id, a kind and an oriented box (centre, yaw about z,
edge lengths along its own axes), in the map frame. Every triangle of the scene knows its
source (`Scene.face_source`): an object id, or LAND / WATER for terrain and the water surface,
so a ray's primitive id says what it hit with one gather.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Sources of a ray return that are no object (object ids are >= 0).
LAND = -1  # terrain: riverbed, shore, valley sides
WATER = -2  # the water surface
NO_RETURN = -3  # radar truth only: a cell no ray reached


@dataclass(frozen=True)
class SceneObjects:
    """k objects, map frame.

    ids : (k,) int64, unique, the value their faces carry in `Scene.face_source`.
    kinds : (k,) str, e.g. "vessel", "buoy", "landing_stage", "tree", "house".
    centre_xyz : (k, 3) float64 metres, centre of the oriented box.
    yaw_rad : (k,) float64, the box's x axis counter-clockwise from map x (east).
    size_xyz : (k, 3) float64 metres, edge lengths along the box's own axes.
    on_water : (k,) bool, True for an object in the river (vessels, buoys, pontoons: what a
        vessel must avoid), False for one on the bank (trees, houses).
    """

    ids: np.ndarray
    kinds: np.ndarray
    centre_xyz: np.ndarray
    yaw_rad: np.ndarray
    size_xyz: np.ndarray
    on_water: np.ndarray

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    @classmethod
    def empty(cls) -> SceneObjects:
        return cls(
            np.empty(0, np.int64),
            np.empty(0, dtype=object),
            np.empty((0, 3)),
            np.empty(0),
            np.empty((0, 3)),
            np.empty(0, bool),
        )

    def concat(self, other: SceneObjects) -> SceneObjects:
        return SceneObjects(
            *(
                np.concatenate([a, b])
                for a, b in (
                    (self.ids, other.ids),
                    (self.kinds, other.kinds),
                    (self.centre_xyz, other.centre_xyz),
                    (self.yaw_rad, other.yaw_rad),
                    (self.size_xyz, other.size_xyz),
                    (self.on_water, other.on_water),
                )
            )
        )

    def in_sensor_frame(
        self, origin: np.ndarray, rotation: np.ndarray, sensor_yaw_rad: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """Centres (k, 3) and yaws (k,) seen from a sensor at `origin` (3,) with rotation
        sensor -> map (3, 3) whose heading is `sensor_yaw_rad` (yaw only: the boxes stay
        upright in a tilted sensor's frame, an approximation for pitched mounts)."""
        centres = (self.centre_xyz - np.asarray(origin)) @ np.asarray(rotation)
        yaws = (self.yaw_rad - sensor_yaw_rad + np.pi) % (2 * np.pi) - np.pi
        return centres, yaws


def object_boxes(
    kind: str,
    vertices: np.ndarray,
    index: np.ndarray,
    positions: np.ndarray,
    yaws_rad: np.ndarray,
    first_id: int,
    *,
    on_water: bool = False,
) -> SceneObjects:
    """Oriented boxes of k instanced objects from their vertices.

    vertices : (n, 3) map frame; index : (n,) int, the instance (0 .. k-1) of each vertex;
    positions : (k, 3) and yaws_rad : (k,) of the instances, whose local axes the boxes take;
    on_water : whether these objects stand in the river (all k alike).
    """
    k = len(positions)
    rel = np.asarray(vertices, np.float64) - np.asarray(positions)[index]
    c, s = np.cos(yaws_rad)[index], np.sin(yaws_rad)[index]
    local = np.column_stack(
        [c * rel[:, 0] + s * rel[:, 1], -s * rel[:, 0] + c * rel[:, 1], rel[:, 2]]
    )
    lo = np.full((k, 3), np.inf)
    hi = np.full((k, 3), -np.inf)
    np.minimum.at(lo, index, local)
    np.maximum.at(hi, index, local)
    mid = 0.5 * (lo + hi)
    yc, ys = np.cos(yaws_rad), np.sin(yaws_rad)
    centre = np.asarray(positions, np.float64) + np.column_stack(
        [yc * mid[:, 0] - ys * mid[:, 1], ys * mid[:, 0] + yc * mid[:, 1], mid[:, 2]]
    )
    return SceneObjects(
        first_id + np.arange(k, dtype=np.int64),
        np.full(k, kind, dtype=object),
        centre,
        np.asarray(yaws_rad, np.float64),
        hi - lo,
        np.full(k, on_water, bool),
    )
