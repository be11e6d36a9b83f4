"""IMU state and message-rate statistics (thesis 3.5.3: the IMU is tracked and displayed).

The thesis saw IMU latency outliers above 80 ms; the gap statistics here make such stalls
visible from header stamps (when the sample was taken) and receive times (when it arrived).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from navigation.config import ImuConfig
from navigation.messages import NS_PER_S, stamp_ns_of


@dataclass(frozen=True)
class RateStats:
    """Statistics of one sequence of times.

    mean_rate_hz : samples per second over the window.
    period_s : the period gaps are judged against (nominal or median interval).
    max_gap_s : largest interval between consecutive samples.
    num_gaps : intervals longer than ``gap_factor`` periods.
    """

    count: int
    mean_rate_hz: float
    period_s: float
    max_gap_s: float
    num_gaps: int


def rate_stats(
    times_ns: np.ndarray, nominal_period_s: float | None = None, gap_factor: float = 2.0
) -> RateStats:
    """Rate and gaps of times_ns : (n,) int64, in arrival order."""
    times = np.asarray(times_ns, dtype=np.int64)
    if times.size < 2:
        return RateStats(int(times.size), 0.0, nominal_period_s or 0.0, 0.0, 0)
    intervals_s = np.diff(times) / NS_PER_S
    span_s = (times[-1] - times[0]) / NS_PER_S
    period_s = nominal_period_s if nominal_period_s is not None else float(np.median(intervals_s))
    return RateStats(
        count=int(times.size),
        mean_rate_hz=float(intervals_s.size / span_s) if span_s > 0 else float("inf"),
        period_s=period_s,
        max_gap_s=float(intervals_s.max()),
        num_gaps=int(np.count_nonzero(intervals_s > gap_factor * period_s)),
    )


@dataclass(frozen=True)
class ImuSnapshot:
    """Latest IMU state and the statistics over the window.

    orientation_xyzw : (4,) quaternion; angular_velocity_rad_s, linear_acceleration_m_s2 :
    (3,). stamps and receive times each give a RateStats; latency_* from stamp to receipt.
    """

    stamp_ns: int
    orientation_xyzw: np.ndarray
    angular_velocity_rad_s: np.ndarray
    linear_acceleration_m_s2: np.ndarray
    stamp_stats: RateStats
    receive_stats: RateStats
    latency_mean_s: float
    latency_max_s: float


class ImuTracker:
    """Keeps the last ``window`` IMU samples in fixed ring buffers (no growth, no lists)."""

    def __init__(self, config: ImuConfig) -> None:
        self._config = config
        size = config.window
        self._stamp_ns = np.zeros(size, dtype=np.int64)
        self._recv_ns = np.zeros(size, dtype=np.int64)
        self._state = np.zeros((size, 10), dtype=np.float64)  # quaternion, gyro, accel
        self._count = 0

    def update(self, msg: dict[str, Any], recv_ns: int) -> None:
        """Record one canonical ``sensor_msgs/msg/Imu`` received at ``recv_ns``."""
        slot = self._count % self._config.window
        q, w, a = msg["orientation"], msg["angular_velocity"], msg["linear_acceleration"]
        self._state[slot] = (
            q["x"],
            q["y"],
            q["z"],
            q["w"],
            w["x"],
            w["y"],
            w["z"],
            a["x"],
            a["y"],
            a["z"],
        )
        self._stamp_ns[slot] = stamp_ns_of(msg["header"])
        self._recv_ns[slot] = recv_ns
        self._count += 1

    def _ordered(self, ring: np.ndarray) -> np.ndarray:
        size = self._config.window
        if self._count <= size:
            return ring[: self._count]
        return np.roll(ring, -(self._count % size), axis=0)

    def snapshot(self) -> ImuSnapshot | None:
        """State and statistics, or None before the first sample."""
        if self._count == 0:
            return None
        stamps, recvs = self._ordered(self._stamp_ns), self._ordered(self._recv_ns)
        latest = self._ordered(self._state)[-1]
        latency_s = (recvs - stamps) / NS_PER_S
        nominal, factor = self._config.nominal_period_s, self._config.gap_factor
        return ImuSnapshot(
            stamp_ns=int(stamps[-1]),
            orientation_xyzw=latest[0:4].copy(),
            angular_velocity_rad_s=latest[4:7].copy(),
            linear_acceleration_m_s2=latest[7:10].copy(),
            stamp_stats=rate_stats(stamps, nominal, factor),
            receive_stats=rate_stats(recvs, nominal, factor),
            latency_mean_s=float(latency_s.mean()),
            latency_max_s=float(latency_s.max()),
        )
