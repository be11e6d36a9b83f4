"""Service health as ``diagnostic_msgs/msg/DiagnosticArray``: IMU rate and gaps, and per
sensor how many messages were processed, skipped (fell behind) or failed, and how long the
processing took. Foxglove and rqt show this type as it is."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from navigation.imu import ImuSnapshot
from navigation.messages import header_msg

OK, WARN, STALE = 0, 1, 3  # diagnostic_msgs/msg/DiagnosticStatus levels (byte)


@dataclass
class SensorCounters:
    """Mutable counters of one sensor pipeline; owned by that sensor's loop task."""

    processed: int = 0
    skipped: int = 0
    failed: int = 0
    last_ms: float = 0.0
    total_ms: float = 0.0
    extra: dict[str, str] = field(default_factory=dict)

    def record(self, elapsed_ms: float) -> None:
        self.processed += 1
        self.last_ms = elapsed_ms
        self.total_ms += elapsed_ms

    @property
    def mean_ms(self) -> float:
        return self.total_ms / self.processed if self.processed else 0.0


def _status(level: int, name: str, message: str, values: dict[str, Any]) -> dict[str, Any]:
    return {
        "level": level,
        "name": name,
        "message": message,
        "hardware_id": "",
        "values": [{"key": k, "value": str(v)} for k, v in values.items()],
    }


def sensor_status(name: str, counters: SensorCounters) -> dict[str, Any]:
    """One status line: WARN once messages were skipped or failed, STALE before any."""
    if counters.processed == 0:
        level, text = STALE, "no message yet"
    elif counters.failed or counters.skipped:
        level, text = WARN, f"{counters.skipped} skipped, {counters.failed} failed"
    else:
        level, text = OK, "ok"
    values = {
        "processed": counters.processed,
        "skipped": counters.skipped,
        "failed": counters.failed,
        "last_ms": f"{counters.last_ms:.2f}",
        "mean_ms": f"{counters.mean_ms:.2f}",
        **counters.extra,
    }
    return _status(level, f"navigation/{name}", text, values)


def imu_status(snapshot: ImuSnapshot | None) -> dict[str, Any]:
    """IMU rate, gap and latency statistics over the tracker's window."""
    if snapshot is None:
        return _status(STALE, "navigation/imu", "no message yet", {})
    stamps, arrivals = snapshot.stamp_stats, snapshot.receive_stats
    level = WARN if stamps.num_gaps or arrivals.num_gaps else OK
    values = {
        "rate_hz": f"{stamps.mean_rate_hz:.2f}",
        "max_gap_s": f"{stamps.max_gap_s:.4f}",
        "gaps": stamps.num_gaps,
        "arrival_max_gap_s": f"{arrivals.max_gap_s:.4f}",
        "arrival_gaps": arrivals.num_gaps,
        "latency_mean_s": f"{snapshot.latency_mean_s:.4f}",
        "latency_max_s": f"{snapshot.latency_max_s:.4f}",
        "angular_velocity_z_rad_s": f"{snapshot.angular_velocity_rad_s[2]:.4f}",
        "linear_acceleration_x_m_s2": f"{snapshot.linear_acceleration_m_s2[0]:.4f}",
    }
    message = f"{stamps.mean_rate_hz:.1f} Hz, {stamps.num_gaps} gaps"
    return _status(level, "navigation/imu", message, values)


def diagnostic_array_msg(
    stamp_ns: int, imu: ImuSnapshot | None, sensors: dict[str, SensorCounters]
) -> dict[str, Any]:
    """Canonical ``diagnostic_msgs/msg/DiagnosticArray``."""
    status = [imu_status(imu)] + [sensor_status(n, c) for n, c in sensors.items()]
    return {"header": header_msg(stamp_ns, ""), "status": status}
