"""IMU tracking and rate/gap statistics."""

from __future__ import annotations

import numpy as np
import pytest

from navigation.config import ImuConfig
from navigation.imu import ImuTracker, rate_stats
from navigation.messages import header_msg

PERIOD_NS = 10_000_000  # 100 Hz


def stamps_with_gap() -> np.ndarray:
    """100 Hz for 2 s with one 85 ms stall (the thesis' >80 ms IMU outliers) after sample 50."""
    stamps = np.arange(200, dtype=np.int64) * PERIOD_NS
    stamps[51:] += 75_000_000
    return stamps


def test_gap_statistics_find_the_known_gap():
    stats = rate_stats(stamps_with_gap())
    assert stats.count == 200
    assert stats.period_s == pytest.approx(0.01)
    assert stats.max_gap_s == pytest.approx(0.085)
    assert stats.num_gaps == 1
    assert stats.mean_rate_hz == pytest.approx(199 / (1.99 + 0.075))


def test_nominal_period_and_factor_are_honoured():
    stamps = np.array([0, 10, 20, 45, 55], dtype=np.int64) * 1_000_000
    assert rate_stats(stamps, nominal_period_s=0.01, gap_factor=2.0).num_gaps == 1
    assert rate_stats(stamps, nominal_period_s=0.01, gap_factor=3.0).num_gaps == 0
    assert rate_stats(stamps[:1]).count == 1 and rate_stats(stamps[:1]).num_gaps == 0


def imu_msg(stamp_ns: int, yaw_rate: float) -> dict:
    return {
        "header": header_msg(stamp_ns, "imu"),
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        "orientation_covariance": [0.0] * 9,
        "angular_velocity": {"x": 0.0, "y": 0.0, "z": yaw_rate},
        "angular_velocity_covariance": [0.0] * 9,
        "linear_acceleration": {"x": 0.1, "y": 0.0, "z": 9.81},
        "linear_acceleration_covariance": [0.0] * 9,
    }


def test_tracker_keeps_latest_state_and_window_statistics(check_canonical):
    tracker = ImuTracker(ImuConfig(window=120))
    assert tracker.snapshot() is None
    stamps = stamps_with_gap()
    for i, stamp in enumerate(stamps.tolist()):
        msg = imu_msg(stamp, yaw_rate=0.001 * i)
        if i == 0:
            check_canonical("sensor_msgs/msg/Imu", msg)
        delay_ns = 90_000_000 if i == 150 else 2_000_000  # one late delivery
        tracker.update(msg, stamp + delay_ns)
    snap = tracker.snapshot()
    assert snap.stamp_ns == stamps[-1]
    assert snap.angular_velocity_rad_s[2] == pytest.approx(0.199)
    np.testing.assert_allclose(snap.linear_acceleration_m_s2, [0.1, 0.0, 9.81])
    assert snap.stamp_stats.count == 120  # the window, not the whole history
    assert snap.stamp_stats.num_gaps == 0  # the stall at 51 has left the window
    assert snap.receive_stats.num_gaps == 1 and snap.receive_stats.max_gap_s == pytest.approx(0.098)
    assert snap.latency_max_s == pytest.approx(0.09)


def test_diagnostics_report_imu_gaps_and_skipped_scans(check_canonical):
    from navigation.diagnostics import SensorCounters, diagnostic_array_msg

    tracker = ImuTracker(ImuConfig())
    for stamp in stamps_with_gap().tolist():
        tracker.update(imu_msg(stamp, 0.0), stamp)
    lidar = SensorCounters(skipped=3)
    lidar.record(12.5)
    msg = diagnostic_array_msg(5, tracker.snapshot(), {"lidar": lidar, "radar": SensorCounters()})
    check_canonical("diagnostic_msgs/msg/DiagnosticArray", msg)
    imu, lidar_status, radar_status = msg["status"]
    assert imu["level"] == 1 and {"key": "gaps", "value": "1"} in imu["values"]
    assert lidar_status["level"] == 1 and lidar_status["message"] == "3 skipped, 0 failed"
    assert radar_status["level"] == 3  # stale: nothing received yet
