"""A LIDAR step that has fallen far behind, usable in the node's worker process.

Files carry the signals (a threading.Event cannot cross into the worker process; a
multiprocessing one cannot be pickled into a call), so the same step blocks a worker
thread and a worker process alike.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navigation.config import LidarConfig
from navigation.lidar import LidarResult, process_scan

POLL_S = 0.01


@dataclass(frozen=True)
class GatedScan:
    """Creates ``entered`` when a scan starts, then waits (at most ``timeout_s``) until
    ``gate`` exists before running the real step."""

    entered: Path
    gate: Path
    timeout_s: float

    def __call__(self, points: np.ndarray, config: LidarConfig) -> LidarResult:
        self.entered.touch()
        deadline_s = time.monotonic() + self.timeout_s
        while not self.gate.exists() and time.monotonic() < deadline_s:
            time.sleep(POLL_S)
        return process_scan(points, config)
