"""The route as a polyline in the map frame: projection, cross-track error, line of sight.

Everything is vectorised over the polyline's segments; a route has tens of points, a control
tick projects one position, so a tick costs a few microseconds of numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Projection:
    """Where a position lies relative to the route.

    along_m : distance along the route to the closest point
    cross_track_m : signed distance to it, positive left of the route (REP 103: y left)
    heading_rad : map yaw of the route's segment there
    """

    along_m: float
    cross_track_m: float
    heading_rad: float


class Route:
    """A polyline of points (n, 2) float, map frame, metres; n >= 2, no repeated points."""

    def __init__(self, points_m: np.ndarray) -> None:
        points = np.asarray(points_m, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
            raise ValueError(f"a route needs (n >= 2, 2) points, got shape {points.shape}")
        steps = np.diff(points, axis=0)
        lengths = np.hypot(steps[:, 0], steps[:, 1])
        if not (lengths > 0).all():
            raise ValueError("a route may not repeat a point")
        self.points_m = points
        self._steps = steps
        self._lengths_m = lengths
        self.cumulative_m = np.concatenate([[0.0], np.cumsum(lengths)])
        self.points_m.setflags(write=False)

    @property
    def length_m(self) -> float:
        return float(self.cumulative_m[-1])

    def project(self, xy_m: tuple[float, float]) -> Projection:
        """The closest point of the route to `xy_m`."""
        offset = np.asarray(xy_m, dtype=np.float64) - self.points_m[:-1]
        t = np.clip((offset * self._steps).sum(axis=1) / self._lengths_m**2, 0.0, 1.0)
        gap = offset - t[:, None] * self._steps
        k = int(np.argmin(np.hypot(gap[:, 0], gap[:, 1])))
        step = self._steps[k]
        cross = (step[0] * offset[k, 1] - step[1] * offset[k, 0]) / self._lengths_m[k]
        along = self.cumulative_m[k] + t[k] * self._lengths_m[k]
        return Projection(float(along), float(cross), float(np.arctan2(step[1], step[0])))

    def point_at(self, along_m: float) -> tuple[float, float]:
        """The route's point `along_m` from its start (clamped to its ends)."""
        s = np.clip(along_m, 0.0, self.length_m)
        x = np.interp(s, self.cumulative_m, self.points_m[:, 0])
        y = np.interp(s, self.cumulative_m, self.points_m[:, 1])
        return float(x), float(y)
