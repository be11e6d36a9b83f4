"""Transverse Mercator / UTM <-> geodetic latitude and longitude, vectorised in numpy.

Krüger's series in the third flattening n to order n^4 (Karney 2011, "Transverse Mercator with
an accuracy of a few nanometers", eqs. 35-36; also the UTM article's formulas), which is good
to well below a millimetre within a UTM zone. Angles are degrees at the interface.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

UTM_SCALE = 0.9996  # k0 on the central meridian
UTM_FALSE_EASTING_M = 500_000.0
UTM_FALSE_NORTHING_SOUTH_M = 10_000_000.0  # southern hemisphere only


@dataclass(frozen=True)
class Ellipsoid:
    semi_major_m: float
    flattening: float

    @property
    def n(self) -> float:
        """Third flattening."""
        return self.flattening / (2.0 - self.flattening)

    @property
    def rectifying_radius_m(self) -> float:
        """A: the meridian arc from equator to pole is A * pi / 2."""
        n = self.n
        return self.semi_major_m / (1 + n) * (1 + n**2 / 4 + n**4 / 64)


WGS84 = Ellipsoid(6_378_137.0, 1 / 298.257223563)  # GRS80 (ETRS89) differs by < 0.1 mm here


def _series(n: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Krüger coefficients alpha (forward), beta (inverse), delta (conformal -> geodetic)."""
    alpha = np.array(
        [
            n / 2 - 2 * n**2 / 3 + 5 * n**3 / 16 + 41 * n**4 / 180,
            13 * n**2 / 48 - 3 * n**3 / 5 + 557 * n**4 / 1440,
            61 * n**3 / 240 - 103 * n**4 / 140,
            49561 * n**4 / 161280,
        ]
    )
    beta = np.array(
        [
            n / 2 - 2 * n**2 / 3 + 37 * n**3 / 96 - n**4 / 360,
            n**2 / 48 + n**3 / 15 - 437 * n**4 / 1440,
            17 * n**3 / 480 - 37 * n**4 / 840,
            4397 * n**4 / 161280,
        ]
    )
    delta = np.array(
        [
            2 * n - 2 * n**2 / 3 - 2 * n**3 + 116 * n**4 / 45,
            7 * n**2 / 3 - 8 * n**3 / 5 - 227 * n**4 / 45,
            56 * n**3 / 15 - 136 * n**4 / 35,
            4279 * n**4 / 630,
        ]
    )
    return alpha, beta, delta


_J2 = 2 * np.arange(1, 5)  # the 2j multipliers of the series terms


def central_meridian_deg(zone: int) -> float:
    return 6.0 * zone - 183.0


def tm_forward(
    lat_deg: npt.ArrayLike,
    lon_deg: npt.ArrayLike,
    lon0_deg: float,
    k0: float = UTM_SCALE,
    ellipsoid: Ellipsoid = WGS84,
) -> tuple[np.ndarray, np.ndarray]:
    """Geodetic (lat, lon) -> transverse Mercator (x east, y north) metres, no false offsets."""
    n = ellipsoid.n
    alpha, _, _ = _series(n)
    phi = np.radians(np.asarray(lat_deg, dtype=np.float64))
    dlam = np.radians(np.asarray(lon_deg, dtype=np.float64) - lon0_deg)
    c = 2 * np.sqrt(n) / (1 + n)
    t = np.sinh(np.arctanh(np.sin(phi)) - c * np.arctanh(c * np.sin(phi)))
    xi_p = np.arctan2(t, np.cos(dlam))
    eta_p = np.arctanh(np.sin(dlam) / np.sqrt(1 + t**2))
    xi_terms = np.sin(_J2 * xi_p[..., None]) * np.cosh(_J2 * eta_p[..., None])
    eta_terms = np.cos(_J2 * xi_p[..., None]) * np.sinh(_J2 * eta_p[..., None])
    scale = k0 * ellipsoid.rectifying_radius_m
    return scale * (eta_p + eta_terms @ alpha), scale * (xi_p + xi_terms @ alpha)


def tm_inverse(
    x_m: npt.ArrayLike,
    y_m: npt.ArrayLike,
    lon0_deg: float,
    k0: float = UTM_SCALE,
    ellipsoid: Ellipsoid = WGS84,
) -> tuple[np.ndarray, np.ndarray]:
    """Transverse Mercator (x east, y north) metres, no false offsets -> (lat, lon) degrees."""
    _, beta, delta = _series(ellipsoid.n)
    scale = k0 * ellipsoid.rectifying_radius_m
    xi = np.asarray(y_m, dtype=np.float64) / scale
    eta = np.asarray(x_m, dtype=np.float64) / scale
    xi_p = xi - (np.sin(_J2 * xi[..., None]) * np.cosh(_J2 * eta[..., None])) @ beta
    eta_p = eta - (np.cos(_J2 * xi[..., None]) * np.sinh(_J2 * eta[..., None])) @ beta
    chi = np.arcsin(np.sin(xi_p) / np.cosh(eta_p))
    phi = chi + np.sin(_J2 * chi[..., None]) @ delta
    lam = np.arctan2(np.sinh(eta_p), np.cos(xi_p))
    return np.degrees(phi), lon0_deg + np.degrees(lam)


def utm_to_latlon(
    easting_m: npt.ArrayLike, northing_m: npt.ArrayLike, zone: int, northern: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """UTM (easting, northing) metres in `zone` -> (lat, lon) degrees on WGS84."""
    false_northing = 0.0 if northern else UTM_FALSE_NORTHING_SOUTH_M
    return tm_inverse(
        np.asarray(easting_m) - UTM_FALSE_EASTING_M,
        np.asarray(northing_m) - false_northing,
        central_meridian_deg(zone),
    )


def latlon_to_utm(
    lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike, zone: int
) -> tuple[np.ndarray, np.ndarray]:
    """(lat, lon) degrees on WGS84 -> UTM (easting, northing) metres in `zone`."""
    x, y = tm_forward(lat_deg, lon_deg, central_meridian_deg(zone))
    false_northing = np.where(np.asarray(lat_deg) < 0, UTM_FALSE_NORTHING_SOUTH_M, 0.0)
    return x + UTM_FALSE_EASTING_M, y + false_northing
