"""Ground truth messages: what the simulator knows, for judging navigation (docs/quality.md).

* `/sim/ground_truth` (`visualization_msgs/msg/MarkerArray`, map frame, latched): one CUBE per
  object (its oriented box), for RViz, Foxglove and the dashboard.
* `/sim/ground_truth/lidar` and `/sim/ground_truth/radar` (`riverbridge_msgs/msg/
  GroundTruthArray`), one per scan with the scan's stamp: the objects the scan's rays reached,
  in the sensor frame, with how many rays each returned; for the radar also what fills each
  cell. A judge pairs them with navigation's outputs of the same stamp.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from schemas.markers import MARKER_ADD, MARKER_CUBE, marker_msg
from schemas.values import Message
from simulator.config import LidarConfig, RadarConfig
from simulator.frames import Pose2D, quaternion_from_yaw, sensor_pose_in_map
from simulator.messages import MAP_FRAME, header
from simulator.objects import SceneObjects
from simulator.scene import Scene

if TYPE_CHECKING:
    from simulator.radar import RadarSweep

TRUTH_TYPE = "riverbridge_msgs/msg/GroundTruthArray"
MARKERS_TYPE = "visualization_msgs/msg/MarkerArray"
KIND_COLOURS = {
    "vessel": (1.0, 0.3, 0.2),
    "buoy": (1.0, 0.5, 0.0),
    "landing_stage": (0.9, 0.8, 0.2),
    "tree": (0.2, 0.8, 0.3),
    "house": (0.7, 0.4, 0.9),
}


def truth_msg(
    sensor: str,
    objects: SceneObjects,
    seen: np.ndarray,
    centres: np.ndarray,
    yaws: np.ndarray,
    stamp_ns: int,
    frame_id: str,
    *,
    water_z_m: float = 0.0,
    dominant_cells: np.ndarray | None = None,
    cell_source: np.ndarray | None = None,
) -> dict[str, Any]:
    """Canonical GroundTruthArray of the objects with ``seen`` > 0.

    seen : (k,) rays of this scan on each object; centres (k, 3), yaws (k,) in the sensor
    frame; water_z_m the water surface in that frame; dominant_cells (k,) and cell_source
    (beams, cells) int32 for the radar.
    """
    index = np.flatnonzero(seen > 0)
    dominant = np.zeros(len(objects), np.int64) if dominant_cells is None else dominant_cells
    items = [
        {
            "id": int(objects.ids[i]),
            "kind": str(objects.kinds[i]),
            "on_water": bool(objects.on_water[i]),
            "center": dict(zip("xyz", centres[i].tolist(), strict=True)),
            "yaw_rad": _f32(yaws[i]),
            "size": dict(zip("xyz", objects.size_xyz[i].tolist(), strict=True)),
            "range_m": _f32(np.hypot(centres[i, 0], centres[i, 1])),
            "returns": int(seen[i]),
            "dominant_cells": int(dominant[i]),
        }
        for i in index.tolist()
    ]
    shape = (0, 0) if cell_source is None else cell_source.shape
    return {
        "header": header(stamp_ns, frame_id),
        "sensor": sensor,
        "objects": items,
        "water_z_m": _f32(water_z_m),
        "num_beams": int(shape[0]),
        "num_cells": int(shape[1]),
        "cell_source": (
            np.empty(0, np.int32)
            if cell_source is None
            else np.ascontiguousarray(cell_source, np.int32).reshape(-1)
        ),
    }


def lidar_truth(
    scene: Scene, cfg: LidarConfig, pose: Pose2D, source: np.ndarray, stamp_ns: int
) -> dict[str, Any]:
    """GroundTruthArray of one LIDAR scan; source : (n,) what each of its points hit."""
    origin, rotation = sensor_pose_in_map(pose, cfg.mount, scene.water_level_m)
    centres, yaws = scene.objects.in_sensor_frame(origin, rotation, pose.yaw_rad)
    seen = counts_per_object(source, len(scene.objects))
    return truth_msg(
        "lidar",
        scene.objects,
        seen,
        centres,
        yaws,
        stamp_ns,
        cfg.frame_id,
        water_z_m=scene.water_level_m - float(origin[2]),
    )


def radar_truth(
    scene: Scene, cfg: RadarConfig, pose: Pose2D, sweep: RadarSweep, stamp_ns: int
) -> dict[str, Any]:
    """GroundTruthArray of one radar sweep, with the dominant source of every cell."""
    origin, rotation = sensor_pose_in_map(pose, cfg.mount, scene.water_level_m)
    centres, yaws = scene.objects.in_sensor_frame(origin, rotation, pose.yaw_rad)
    dominant = counts_per_object(sweep.cell_source.reshape(-1), len(scene.objects))
    return truth_msg(
        "radar",
        scene.objects,
        sweep.object_rays,
        centres,
        yaws,
        stamp_ns,
        cfg.frame_id,
        water_z_m=scene.water_level_m - float(origin[2]),
        dominant_cells=dominant,
        cell_source=sweep.cell_source,
    )


def counts_per_object(source: np.ndarray, count: int) -> np.ndarray:
    """(count,) how often each object id occurs in ``source`` (negative sources ignored)."""
    ids = source[source >= 0]
    return np.bincount(ids, minlength=count)[:count]


def markers_msg(objects: SceneObjects, stamp_ns: int) -> dict[str, Any]:
    """Canonical MarkerArray: one CUBE per object, map frame, namespace = kind, id = id."""
    markers = []
    for i in range(len(objects)):
        kind = str(objects.kinds[i])
        rgb = KIND_COLOURS.get(kind, (0.8, 0.8, 0.8))
        qx, qy, qz, qw = quaternion_from_yaw(float(objects.yaw_rad[i]))
        markers.append(
            _marker(
                stamp_ns,
                kind,
                int(objects.ids[i]),
                {
                    "position": dict(zip("xyz", objects.centre_xyz[i].tolist(), strict=True)),
                    "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
                },
                dict(zip("xyz", np.maximum(objects.size_xyz[i], 0.01).tolist(), strict=True)),
                rgb,
            )
        )
    return {"markers": markers}


def _marker(
    stamp_ns: int,
    ns: str,
    marker_id: int,
    pose: Message,
    scale: Message,
    rgb: tuple[float, float, float],
) -> dict[str, Any]:
    """A canonical visualization_msgs/msg/Marker CUBE with every other field at its default."""
    return marker_msg(
        header(stamp_ns, MAP_FRAME),
        ns,
        marker_id,
        MARKER_CUBE,
        MARKER_ADD,
        pose=pose,
        scale=scale,
        # ColorRGBA is float32: values that float32 holds exactly keep every encoding equal
        color={"r": _f32(rgb[0]), "g": _f32(rgb[1]), "b": _f32(rgb[2]), "a": _f32(0.4)},
    )


def _f32(value: float) -> float:
    return float(np.float32(value))
