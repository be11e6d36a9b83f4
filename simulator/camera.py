"""Camera (thesis table 4.5): a pinhole image ray cast through every pixel, JPEG-encoded.

Shading is deliberately simple: material colour x (ambient + Lambert sun term, one value per
triangle, computed once per scene), a sky gradient where rays escape, and aerial haze with
distance so the horizon reads as one. The image is drawn in the ROS optical frame (x right,
y down, z forward).
"""

from __future__ import annotations

from functools import partial

import cv2
import numpy as np

from schemas.catalogue import TOPICS
from schemas.values import Message
from simulator.config import CameraConfig, SimConfig
from simulator.frames import Pose2D, mount_rotation, rotate_rows, sensor_pose_in_map
from simulator.messages import compressed_image
from simulator.raycast import RayCaster, fill_origins
from simulator.scene import Scene
from simulator.sensor import Capture, Generated, Schedule, SensorFrame

# Optical frame (x right, y down, z forward) -> camera body frame (x forward, y left, z up).
OPTICAL_TO_BODY = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
SKY_HORIZON_RGB = np.array([200.0, 215.0, 230.0], np.float32)
SKY_ZENITH_RGB = np.array([90.0, 140.0, 205.0], np.float32)
HAZE_DISTANCE_M = 2500.0  # distance at which haze has taken ~63 % of the colour


def pixel_directions(cfg: CameraConfig) -> np.ndarray:
    """(height * width, 3) float32 unit rays through pixel centres, camera body frame.

    Square pixels; focal length from the vertical field of view.
    """
    focal_px = 0.5 * cfg.height_px / np.tan(np.radians(cfg.vertical_fov_deg) / 2)
    u = np.arange(cfg.width_px) + 0.5 - cfg.width_px / 2
    v = np.arange(cfg.height_px) + 0.5 - cfg.height_px / 2
    gu, gv = np.meshgrid(u, v)
    optical = np.stack([gu, gv, np.full_like(gu, focal_px)], axis=-1).reshape(-1, 3)
    optical /= np.linalg.norm(optical, axis=1, keepdims=True)
    return np.ascontiguousarray(optical @ OPTICAL_TO_BODY.T, dtype=np.float32)


def sky_colours_bgr(directions_body: np.ndarray, cfg: CameraConfig) -> np.ndarray:
    """(n, 3) float32 BGR sky for each ray: a gradient from horizon to zenith.

    The vessel only yaws, so a ray's elevation in the map frame is fixed by the mount pitch
    and the sky behind every pixel can be computed once.
    """
    up = (directions_body @ mount_rotation(cfg.mount).T)[:, 2:3].clip(0.0, 1.0)
    sky_rgb = SKY_HORIZON_RGB + (SKY_ZENITH_RGB - SKY_HORIZON_RGB) * up
    return np.ascontiguousarray(sky_rgb[:, ::-1], dtype=np.float32)


class Camera:
    """Renders (height, width, 3) uint8 BGR frames of a `Scene` and encodes them as JPEG."""

    def __init__(self, cfg: CameraConfig | None = None, *, threads: int = 2) -> None:
        self.cfg = cfg or CameraConfig()
        self.directions_body = pixel_directions(self.cfg)
        n = len(self.directions_body)
        self._directions_map = np.empty((n, 3), np.float32)
        self._origins = np.empty((n, 3), np.float32)
        self._bgr = np.empty((n, 3), np.float32)
        self._sky_bgr = sky_colours_bgr(self.directions_body, self.cfg)
        self._caster = RayCaster(threads)
        sun = np.asarray(self.cfg.sun_direction_xyz, np.float32)
        self._sun = sun / np.linalg.norm(sun)
        self._lit: tuple[Scene, np.ndarray] | None = None

    def close(self) -> None:
        self._caster.close()

    def render(self, scene: Scene, pose: Pose2D) -> np.ndarray:
        """returns image : (height, width, 3) uint8, BGR (OpenCV order)."""
        cfg = self.cfg
        origin, rotation = sensor_pose_in_map(pose, cfg.mount, scene.water_level_m)
        rotate_rows(self.directions_body, rotation, self._directions_map)
        fill_origins(self._origins, origin)
        image = np.empty((cfg.height_px * cfg.width_px, 3), np.uint8)
        lit = self._lit_colours(scene)
        self._caster.map_chunks(
            scene,
            self._origins,
            self._directions_map,
            cfg.max_range_m,
            partial(self._shade_chunk, lit, image),
        )
        return image.reshape(cfg.height_px, cfg.width_px, 3)

    def _shade_chunk(
        self,
        lit_bgr: np.ndarray,
        image: np.ndarray,
        chunk: slice,
        range_m: np.ndarray,
        prim: np.ndarray,
    ) -> None:
        """Shade one chunk of pixels into `image[chunk]` (runs on a ray-casting thread):
        the sky everywhere, then material colour hazed by range where a triangle was hit."""
        bgr = self._bgr[chunk]
        np.copyto(bgr, self._sky_bgr[chunk])
        hit = np.flatnonzero(prim >= 0)
        hit_range_m = np.take(range_m, hit)
        haze = 1.0 - np.exp(-hit_range_m / HAZE_DISTANCE_M)
        colour = np.take(lit_bgr, np.take(prim, hit), axis=0)
        colour *= (1.0 - haze)[:, None]
        colour += haze[:, None] * SKY_HORIZON_RGB[::-1]
        bgr[hit] = colour
        np.clip(bgr, 0.0, 255.0, out=bgr)
        image[chunk] = bgr

    def _lit_colours(self, scene: Scene) -> np.ndarray:
        """(f, 3) float32 BGR of every triangle under the sun (ambient + Lambert), cached per scene.

        The sun is fixed and meshes are closed with outward normals (terrain and water face up),
        so the visible side of a triangle is its front and its shade does not depend on the view.
        """
        if self._lit is None or self._lit[0] is not scene:
            lambert = np.clip(scene.face_normals @ self._sun, 0.0, 1.0)
            light = self.cfg.ambient + (1.0 - self.cfg.ambient) * lambert
            bgr = scene.colour_rgb[:, ::-1].astype(np.float32) * light[:, None]
            self._lit = (scene, bgr)
        return self._lit[1]

    def encode(self, image: np.ndarray) -> bytes:
        """JPEG bytes of a BGR image at `cfg.jpeg_quality`."""
        ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.cfg.jpeg_quality])
        if not ok:
            raise RuntimeError("OpenCV failed to encode the camera frame as JPEG")
        return jpeg.tobytes()

    def message(self, jpeg: bytes, stamp_ns: int) -> Message:
        """sensor_msgs/msg/CompressedImage of one frame, stamped with its capture time."""
        return compressed_image(jpeg, stamp_ns, self.cfg.frame_id)


class CameraSensor:
    """The simulator's camera (simulator.sensor): a rendered JPEG frame per tick on its
    worker thread, in the optical frame."""

    topic = TOPICS["camera"]
    schedule: Schedule = "worker"

    def __init__(self, cfg: SimConfig, scene: Scene) -> None:
        self._scene = scene
        self.camera = Camera(cfg.camera, threads=2)
        self.frame = SensorFrame(cfg.camera.frame_id, cfg.camera.mount, OPTICAL_TO_BODY)

    def generate(self, capture: Capture) -> Generated:
        image = self.camera.render(self._scene, capture.pose)
        return Generated(self.camera.message(self.camera.encode(image), capture.stamp_ns))

    def close(self) -> None:
        self.camera.close()
