"""Guidance configuration: frozen pydantic models; a misspelt key in a TOML file is named.

config/guidance.toml lists every field with its default and where it comes from ("ours":
the thesis gives no guidance or control values; its section 5.2 only names the subsystems).
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

# The default scene's river centre line (seed 7) from the start pose 1.4 km downstream, one
# point per 50 m of northing, in UTM 32N: an inland chart's fairway, as a route plan would
# give it. tests/guidance/test_route.py checks it against the scene.
DEFAULT_ROUTE_UTM: tuple[tuple[float, float], ...] = (
    (384003.9, 5719400.0),
    (384024.6, 5719450.0),
    (384049.3, 5719500.0),
    (384073.6, 5719550.0),
    (384092.8, 5719600.0),
    (384103.6, 5719650.0),
    (384104.7, 5719700.0),
    (384097.6, 5719750.0),
    (384085.7, 5719800.0),
    (384073.3, 5719850.0),
    (384064.7, 5719900.0),
    (384062.4, 5719950.0),
    (384066.8, 5720000.0),
    (384075.7, 5720050.0),
    (384085.2, 5720100.0),
    (384090.8, 5720150.0),
    (384088.9, 5720200.0),
    (384077.7, 5720250.0),
    (384058.0, 5720300.0),
    (384032.8, 5720350.0),
    (384006.5, 5720400.0),
    (383983.8, 5720450.0),
    (383968.2, 5720500.0),
    (383961.0, 5720550.0),
    (383961.1, 5720600.0),
    (383965.1, 5720650.0),
    (383968.8, 5720700.0),
    (383968.1, 5720750.0),
    (383960.6, 5720800.0),
)


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class RouteConfig(_Frozen):
    """Waypoints in UTM and where the map frame's origin lies in UTM."""

    # The simulator's map origin (its [gnss] origin; thesis 3.5.1: the centre of the area).
    origin_easting_m: float = 384000.0
    origin_northing_m: float = 5720000.0
    waypoints_utm: Annotated[tuple[tuple[float, float], ...], Field(min_length=2)] = (
        DEFAULT_ROUTE_UTM
    )
    # Aim at the route this far ahead of the closest point (line-of-sight guidance): about
    # four hull lengths, so the vessel converges on the line without weaving.
    lookahead_m: Annotated[float, Field(gt=0)] = 30.0
    arrival_m: Annotated[float, Field(ge=0)] = 20.0  # stop this far before the route's end

    @model_validator(mode="after")
    def _distinct(self) -> RouteConfig:
        for k, (a, b) in enumerate(zip(self.waypoints_utm, self.waypoints_utm[1:], strict=False)):
            if a == b:
                raise ValueError(f"waypoints_utm repeats point {k} at {k + 1}")
        return self


class SpeedConfig(_Frozen):
    cruise_mps: Annotated[float, Field(gt=0)] = 3.5  # ~7 kn: 77 % of the hull's top speed


class AvoidanceConfig(_Frozen):
    """Corridor search on the obstacle map (guidance.avoidance)."""

    # Free water kept beside the hull: with the margin the corridor is 23.5 m wide, so the
    # vessel passes an obstacle that leaves 25 m of open water beside it.
    clearance_m: Annotated[float, Field(gt=0)] = 8.0
    # Added to the corridor for what the clearance loses between plan and water: the hull
    # swinging as it turns back (0.4 m with perfect sensing on the 3-DOF model), the obstacle
    # map's cells (0.5 m grid, 4 m radar range cells), perception's delay under load.
    # Measured closest passes: docs/guidance.md.
    margin_m: Annotated[float, Field(ge=0)] = 2.5
    need_m: Annotated[float, Field(gt=0)] = 50.0  # free run a heading needs to be taken
    range_m: Annotated[float, Field(gt=0)] = 80.0  # look no further (the obstacle map's reach)
    stop_distance_m: Annotated[float, Field(ge=0)] = 15.0  # nothing free beyond this: stop
    fan_deg: Annotated[float, Field(gt=0, le=180)] = 70.0  # candidates either side of the route
    fan_step_deg: Annotated[float, Field(gt=0)] = 2.0
    switch_penalty: Annotated[float, Field(ge=0)] = 0.5  # per rad away from the last choice
    ignore_within_m: Annotated[float, Field(ge=0)] = 4.5  # the hull's own returns
    beam_m: Annotated[float, Field(gt=0)] = 2.5  # the simulator's [vessel] beam_m
    # Sensors sit axis-aligned in base_link (the simulator's mounts, navigation's [fusion]).
    lidar_offset_xy_m: tuple[float, float] = (0.0, 0.0)
    radar_offset_xy_m: tuple[float, float] = (0.0, 0.0)
    max_obstacle_z_m: float = 20.0  # boxes wholly above (bridges, lines) are no obstacle

    @model_validator(mode="after")
    def _ordered(self) -> AvoidanceConfig:
        if not self.stop_distance_m < self.need_m <= self.range_m:
            raise ValueError("need stop_distance_m < need_m <= range_m")
        return self


class ControlConfig(_Frozen):
    """Heading and speed loops (guidance.control says how the gains were chosen)."""

    rate_hz: Annotated[float, Field(ge=10, le=20)] = 10.0  # issue 26: 10-20 Hz
    heading_kp: Annotated[float, Field(ge=0)] = 6000.0  # N m per rad (an unstable hull)
    heading_kd: Annotated[float, Field(ge=0)] = 12000.0  # N m s per rad
    speed_kp: Annotated[float, Field(ge=0)] = 1100.0  # N s/m: a 2 s time constant
    speed_ki: Annotated[float, Field(ge=0)] = 110.0  # N/m
    # Feed-forward: the simulator's [vessel] d_u and d_u2 (what holds a speed in still water).
    surge_damping_n_per_mps: Annotated[float, Field(ge=0)] = 200.0
    surge_damping_quadratic: Annotated[float, Field(ge=0)] = 150.0
    max_surge_force_n: Annotated[float, Field(gt=0)] = 4000.0  # [vessel] max_surge_force_n
    max_yaw_moment_nm: Annotated[float, Field(gt=0)] = 6000.0  # [vessel] max_yaw_moment_nm


class InputsConfig(_Frozen):
    """How old navigation's output and the odometry may be, and the operator's override."""

    slow_age_s: Annotated[float, Field(gt=0)] = 1.5  # three 2 Hz scans missed: slow down
    stop_age_s: Annotated[float, Field(gt=0)] = 3.0  # six missed: stop rather than drive blind
    pose_max_age_s: Annotated[float, Field(gt=0)] = 1.0  # 50 odometry samples at 50 Hz
    operator_override_s: Annotated[float, Field(gt=0)] = 5.0  # a person's /cmd_wrench wins

    @model_validator(mode="after")
    def _ordered(self) -> InputsConfig:
        if not self.slow_age_s < self.stop_age_s:
            raise ValueError("need slow_age_s < stop_age_s")
        return self


class GuidanceConfig(_Frozen):
    route: RouteConfig = RouteConfig()
    speed: SpeedConfig = SpeedConfig()
    avoidance: AvoidanceConfig = AvoidanceConfig()
    control: ControlConfig = ControlConfig()
    inputs: InputsConfig = InputsConfig()


def load_config(path: str | Path) -> GuidanceConfig:
    """Read a TOML file into a `GuidanceConfig`; missing tables and fields take the defaults."""
    with Path(path).open("rb") as stream:
        return GuidanceConfig.model_validate(tomllib.load(stream))
