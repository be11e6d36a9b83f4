"""Configuration of the navigation service: frozen pydantic models, loadable from TOML.

Defaults are the thesis values (tables 4.2, 4.3, 4.4, 4.6) where the thesis gives one; the
remaining values are ours and their comment says why. config/nav.toml lists every field with
its default and source. ``extra="forbid"`` makes a misspelt
field fail loudly with its name instead of being silently ignored.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

ClusterMethod = Literal["dbscan", "kmeans", "birch"]
LidarWorkerKind = Literal["process", "thread"]
CfarKind = Literal["ca", "soca", "goca", "os"]
CfarAxis = Literal["azimuth", "range"]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class GroundConfig(_Frozen):
    """Water and terrain removal ahead of clustering (cost follows neighbour count, see
    performance-measurements §2(e): the dense ground near the sensor is what makes DBSCAN slow)."""

    # Water surface height in the cloud's frame; None estimates it as the most populated
    # height bin below the sensor (the water plane is flat and returns many points).
    water_level_z_m: float | None = None
    water_margin_m: float = 0.3  # waves / float32 noise above the plane still count as water
    cell_size_m: float = 1.0  # resolution of the local-ground height grid
    # Morphological opening width: objects narrower than this stand out of the ground estimate;
    # linear slopes (river banks) pass through an opening unchanged.
    opening_width_m: float = 11.0
    ground_margin_m: float = 0.3  # points this close above the local ground are terrain
    height_bin_m: float = 0.1  # histogram bin for the water-level estimate


class LidarConfig(_Frozen):
    """LIDAR obstacle extraction (thesis 2.4, 3.5.3, tables 4.3 and 4.4)."""

    range_min_m: float = 1.5  # drops returns from the own hull and mast
    range_max_m: float = 100.0  # thesis 3.3.1: the Velodyne Puck's range, up to 100 m
    ground: GroundConfig = GroundConfig()
    # Voxel edge; 0 disables. 0.2 m keeps the same 54 clusters as the full cloud in
    # performance-measurements §2(e) at a fifth of the DBSCAN time.
    voxel_size_m: float = Field(default=0.2, ge=0.0)
    method: ClusterMethod = "dbscan"
    eps_m: float = Field(default=1.0, gt=0.0)  # thesis table 4.4: Eps 1
    min_samples: int = Field(default=10, ge=1)  # thesis table 4.4: MinPts 10
    # Adaptive eps of thesis eq. 2.4.9: eps_i = n * theta * pi * d_i / 180.
    adaptive_eps: bool = False
    angular_resolution_deg: float = 0.25  # thesis table 4.3: 0.25 deg horizontal resolution
    eps_precision_factor: float = 5.0  # thesis eq. 2.4.9 "n"; 5 gives 2.2 m at 100 m
    # Floor of the adaptive eps: table 4.4's Eps, so the arc-length rule only widens eps for
    # far, sparse objects (beyond 46 m with the defaults) and never splits near ones.
    eps_min_m: float = 1.0
    n_clusters: int = Field(default=30, ge=1)  # K-means only (thesis 2.4.2 needs k up front)
    birch_threshold_m: float = Field(default=0.5, gt=0.0)  # BIRCH radius limit T (thesis 2.4.3)
    box_max_size_m: float = Field(
        default=3.0, gt=0.0
    )  # thesis table 4.4: bounding box resolution 3
    # True shrinks each sub-box to the points it holds; False keeps the halved boxes of
    # thesis figure 18.
    shrink_boxes: bool = False
    # scikit-learn neighbour-query workers; one keeps the second core for the other sensors
    # (on the ~1-5k obstacle points left after filtering, -1 measured slower here).
    n_jobs: int | None = None
    # Where the LIDAR step runs (ours, DESIGN §4): "process", a warm worker process, keeps
    # scikit-learn's GIL-holding stretches off the event loop that reads the IMU; "thread",
    # a thread of the navigation process (no extra process; IMU tail of tens of ms under load).
    worker: LidarWorkerKind = "process"

    @model_validator(mode="after")
    def _check_range(self) -> LidarConfig:
        if not 0.0 <= self.range_min_m < self.range_max_m:
            raise ValueError("need 0 <= range_min_m < range_max_m")
        return self


class CfarConfig(_Frozen):
    """Radar CFAR detector (thesis 2.5, table 4.2) and the grouping of its cells into targets.

    Thesis 4.1 reads table 4.2 as totals: "A total of 100 cells are taken into consideration
    ... Ten cells that are five to the right and five to the left of the CUT are ignored": 50
    training and 5 guard cells on each side of the cell under test. That window spans 111
    cells, and the thesis radar has 25 range cells (table 4.1: 100 m of 4 m cells) and 72
    beams (5 deg), so it fits neither axis. The window here runs along azimuth (the ring of 72
    beams at the CUT's range, see navigation.cfar and docs/quality.md) with table 4.2's 5
    guard cells per side and the 30 training cells per side that the ring holds beside them
    (72 - 1 - 2 x 5 = 61). A window that does not fit the image is an error naming these
    fields, not a silently smaller window.
    """

    detector: CfarKind = "soca"  # thesis 3.5.3 uses SOCA-CFAR
    # "azimuth": reference cells in the neighbouring beams at the same range (wraps around);
    # "range": along the beam, one-sided near the row ends.
    axis: CfarAxis = "azimuth"
    # table 4.2 has 100 in total; 30 per side is what a ring of 72 beams holds (see above)
    training_cells_per_side: int = Field(default=30, ge=1)
    guard_cells_per_side: int = Field(default=5, ge=0)  # thesis table 4.2: 10 guard in total
    false_alarm_rate: float = Field(default=0.1, gt=0.0, lt=1.0)  # thesis table 4.2
    # OS-CFAR order k among the 2 * training_cells_per_side reference cells; None picks
    # 3/4 of them, the usual choice (Rohling 1983) that tolerates interfering targets.
    os_rank: int | None = None
    frame_id: str = "radar"

    @model_validator(mode="after")
    def _check_rank(self) -> CfarConfig:
        if self.os_rank is not None and not 1 <= self.os_rank <= 2 * self.training_cells_per_side:
            raise ValueError("os_rank must lie in 1 .. 2 * training_cells_per_side")
        return self


class CameraConfig(_Frozen):
    """Canny edges and Hough lines (thesis 3.5.3, table 4.6)."""

    canny_threshold1: float = 170.0  # thesis table 4.6
    canny_threshold2: float = 260.0  # thesis table 4.6
    rho_px: float = 1.1  # thesis table 4.6
    theta_deg: float = 1.0  # thesis table 4.6
    threshold: int = 190  # thesis table 4.6: accumulator votes
    probabilistic: bool = False  # thesis uses standard Hough
    min_line_length_px: float = 50.0  # probabilistic Hough only
    max_line_gap_px: float = 10.0  # probabilistic Hough only


class ImuConfig(_Frozen):
    """IMU rate and gap statistics."""

    window: int = Field(default=1000, ge=2)  # samples kept for the statistics
    # Nominal sample period; None takes the median stamp interval of the window.
    nominal_period_s: float | None = None
    gap_factor: float = 2.0  # a gap is an interval above this many periods


class FusionConfig(_Frozen):
    """Vessel-centred obstacle grid from LIDAR boxes and radar targets (thesis figure 3.21)."""

    frame_id: str = "base_link"
    size_m: float = Field(default=200.0, gt=0.0)  # square side; covers the 100 m sensor ranges
    resolution_m: float = Field(default=0.5, gt=0.0)
    publish_rate_hz: float = 2.0  # the LIDAR rate, thesis 4.1
    lidar_offset_xy_m: tuple[float, float] = (0.0, 0.0)  # sensor origins in the vessel frame
    radar_offset_xy_m: tuple[float, float] = (0.0, 0.0)
    # coverage: cells beyond every sensor's range are unknown
    lidar_range_m: float = 100.0  # thesis 3.3.1: the Velodyne Puck's 100 m
    radar_range_m: float = 100.0  # thesis 4.1: the virtual radar's ~100 m
    # Boxes wholly above this height (bridges, overhead lines) are no obstacle to the hull.
    max_obstacle_z_m: float = 20.0


class NavigationConfig(_Frozen):
    """Everything the navigation service needs."""

    lidar: LidarConfig = LidarConfig()
    cfar: CfarConfig = CfarConfig()
    camera: CameraConfig = CameraConfig()
    imu: ImuConfig = ImuConfig()
    fusion: FusionConfig = FusionConfig()


def load_config(path: str | Path) -> NavigationConfig:
    """Read a TOML file whose tables mirror NavigationConfig (``[lidar]``, ``[cfar]`` ...)."""
    with Path(path).open("rb") as f:
        return NavigationConfig.model_validate(tomllib.load(f))
