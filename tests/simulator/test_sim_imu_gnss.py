"""IMU (gravity at rest, turning, noise) and GNSS (transverse Mercator, NavSatFix)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from simulator.config import GnssConfig, ImuConfig, MountConfig, VesselConfig
from simulator.dynamics import Command, Pose2D, StepResult, VesselDynamics, VesselState
from simulator.gnss import Gnss
from simulator.imu import Imu
from simulator.utm import WGS84, Ellipsoid, latlon_to_utm, tm_forward, utm_to_latlon


def at_rest(yaw_rad: float = 0.0) -> StepResult:
    return VesselDynamics().step(VesselState(yaw_rad=yaw_rad), Command())


def test_imu_at_rest_reads_gravity():
    reading = Imu().measure(at_rest(yaw_rad=0.7))
    np.testing.assert_allclose(reading.linear_acceleration_mps2, [0.0, 0.0, 9.80665], atol=1e-9)
    np.testing.assert_allclose(reading.angular_velocity_radps, 0.0, atol=1e-12)
    assert reading.orientation_xyzw == pytest.approx((0.0, 0.0, np.sin(0.35), np.cos(0.35)))


def test_imu_in_a_steady_turn_reads_the_centripetal_acceleration():
    dynamics = VesselDynamics(VesselConfig())
    state = VesselState()
    for _ in range(60 * 50):
        result = dynamics.step(state, Command(2000.0, 1500.0))
        state = result.state
    centred = Imu(ImuConfig(mount=MountConfig(x_m=0.0, y_m=0.0, z_m=0.5))).measure(result)
    assert centred.angular_velocity_radps[2] == pytest.approx(state.r_radps)
    assert centred.linear_acceleration_mps2[1] == pytest.approx(
        state.u_mps * state.r_radps, rel=1e-3
    )
    # 2 m forward of the yaw axis adds -r^2 * 2 m along x (pointing back at the axis).
    forward = Imu(ImuConfig(mount=MountConfig(x_m=2.0, z_m=0.5))).measure(result)
    delta = forward.linear_acceleration_mps2 - centred.linear_acceleration_mps2
    assert delta[0] == pytest.approx(-2.0 * state.r_radps**2, rel=1e-6)


def test_imu_noise_and_bias_are_seeded():
    cfg = ImuConfig(accel_noise_std_mps2=0.05, gyro_noise_std_radps=0.01, accel_bias_std_mps2=0.1)
    step = at_rest()
    first = np.array([Imu(cfg, seed=5).measure(step).linear_acceleration_mps2 for _ in range(2)])
    np.testing.assert_array_equal(first[0], first[1])
    imu = Imu(cfg, seed=5)
    samples = np.array([imu.measure(step).linear_acceleration_mps2 for _ in range(2000)])
    assert samples.std(axis=0) == pytest.approx([0.05] * 3, rel=0.1)
    bias = samples.mean(axis=0) - [0.0, 0.0, 9.80665]
    assert np.all(np.abs(bias) > 0.0) and np.all(np.abs(bias) < 0.5)


def test_imu_message(check_canonical):
    imu = Imu(ImuConfig(gyro_noise_std_radps=0.01))
    msg = imu.message(imu.measure(at_rest()), stamp_ns=1_000_000_001)
    assert msg["header"] == {"stamp": {"sec": 1, "nanosec": 1}, "frame_id": "imu"}
    assert msg["angular_velocity_covariance"][0] == pytest.approx(1e-4)
    assert all(len(msg[k]) == 9 for k in msg if k.endswith("covariance"))
    check_canonical("sensor_msgs/msg/Imu", msg)


def test_transverse_mercator_reproduces_snyders_published_example():
    # USGS Professional Paper 1395 (Snyder 1987), p. 269: Clarke 1866, lat 40.5 N, lon 73.5 W,
    # central meridian 75 W, k0 = 0.9996 -> x = 127,106.5 m, y = 4,484,124.4 m.
    clarke1866 = Ellipsoid(6_378_206.4, 1 - 6_356_583.8 / 6_378_206.4)
    x, y = tm_forward(40.5, -73.5, -75.0, 0.9996, clarke1866)
    assert (float(x), float(y)) == pytest.approx((127_106.5, 4_484_124.4), abs=0.06)


def meridian_arc_m(lat_deg: float) -> float:
    """Meridian arc length by numerical quadrature of the meridian radius of curvature."""
    a, f = WGS84.semi_major_m, WGS84.flattening
    e2 = f * (2 - f)
    radius = lambda phi: a * (1 - e2) / (1 - e2 * np.sin(phi) ** 2) ** 1.5  # noqa: E731
    return quad(radius, 0.0, np.radians(lat_deg), epsabs=1e-6)[0]


@pytest.mark.parametrize("lat_deg", [0.0, 30.0, 51.6, 75.0])
def test_northing_on_the_central_meridian_is_the_scaled_meridian_arc(lat_deg):
    easting, northing = latlon_to_utm(lat_deg, 9.0, zone=32)
    assert float(easting) == pytest.approx(500_000.0, abs=1e-6)
    assert float(northing) == pytest.approx(0.9996 * meridian_arc_m(lat_deg), abs=1e-3)


def test_round_trip_across_the_zone():
    rng = np.random.default_rng(1)
    lat = rng.uniform(45.0, 56.0, 500)
    lon = rng.uniform(6.0, 12.0, 500)
    easting, northing = latlon_to_utm(lat, lon, zone=32)
    lat2, lon2 = utm_to_latlon(easting, northing, zone=32)
    np.testing.assert_allclose(lat2, lat, atol=1e-10)  # ~10 micrometres
    np.testing.assert_allclose(lon2, lon, atol=1e-10)


def test_thesis_location_is_in_the_ruhr_area():
    lat, lon = utm_to_latlon(384_000.0, 5_720_000.0, zone=32)
    assert 51.5 < float(lat) < 51.7 and 7.2 < float(lon) < 7.4


def test_gnss_fix_and_message(check_canonical):
    cfg = GnssConfig(mount=MountConfig(z_m=3.0))
    lat, lon, alt = Gnss(cfg).fix(Pose2D(100.0, -50.0, 0.0))
    lat_ref, lon_ref = utm_to_latlon(384_100.0, 5_719_950.0, zone=32)
    assert (lat, lon) == pytest.approx((float(lat_ref), float(lon_ref)), abs=1e-12)
    assert alt == pytest.approx(cfg.water_level_altitude_m + 3.0)
    msg = Gnss(cfg).message((lat, lon, alt), stamp_ns=7)
    assert msg["status"] == {"status": 0, "service": 1}
    assert msg["position_covariance_type"] == 2
    check_canonical("sensor_msgs/msg/NavSatFix", msg)


def test_gnss_noise_is_seeded():
    cfg = GnssConfig(horizontal_noise_std_m=2.0)
    fixes = [Gnss(cfg, seed=9).fix(Pose2D(0, 0, 0)) for _ in range(2)]
    assert fixes[0] == fixes[1]
    assert fixes[0] != Gnss(GnssConfig()).fix(Pose2D(0, 0, 0))
