"""The LIDAR step in a worker process: same boxes as in-process, any input strides, a
buffer that grows, recovery from a dead worker, and nothing left behind by ``close``."""

from __future__ import annotations

import os
import signal
from multiprocessing.shared_memory import SharedMemory

import numpy as np
import pytest

from navigation.config import LidarConfig
from navigation.lidar import LidarResult, process_scan
from navigation.lidar_worker import ProcessLidarWorker, ThreadLidarWorker, lidar_worker_for
from tests.navigation.nav_scenes import default_scene, lidar_directions, raycast

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def points() -> np.ndarray:
    """(n, 4) float32: the test scene's 8 objects above the water."""
    scan, _ = raycast(default_scene(), lidar_directions(0.5, 0.5))
    return np.ascontiguousarray(scan, np.float32)


@pytest.fixture
def worker():
    lidar = ProcessLidarWorker(LidarConfig())
    yield lidar
    lidar.close()


def assert_same_boxes(got: LidarResult, points: np.ndarray) -> None:
    expected = process_scan(points, LidarConfig())
    assert got.num_clusters == expected.num_clusters > 0
    np.testing.assert_array_equal(got.boxes.min_xyz, expected.boxes.min_xyz)
    np.testing.assert_array_equal(got.boxes.max_xyz, expected.boxes.max_xyz)
    np.testing.assert_array_equal(got.boxes.num_points, expected.boxes.num_points)
    np.testing.assert_array_equal(got.labels, expected.labels)


def test_process_worker_finds_the_boxes_of_the_in_process_step(worker, points):
    result = worker(points)
    assert_same_boxes(result, points)
    assert worker.pid is not None and worker.pid != os.getpid()
    assert result.steps.keys() == {"filter", "dbscan", "boxes"}
    for start_ns, end_ns in result.steps.values():
        assert start_ns <= end_ns


def test_process_worker_takes_strided_views_and_larger_scans(worker, points):
    worker(points[: len(points) // 2])  # the shared buffer is sized for half a scan first
    padded = np.zeros((len(points), 5), np.float32)  # point_step 20: a strided view
    padded[:, :4] = points
    assert_same_boxes(worker(padded[:, :4]), points)


def test_a_killed_worker_fails_one_scan_and_the_next_starts_a_new_one(worker, points):
    worker.start()
    first_pid = worker.pid
    os.kill(first_pid, signal.SIGKILL)
    with pytest.raises(Exception, match="terminated abruptly"):
        worker(points)
    assert_same_boxes(worker(points), points)
    assert worker.pid not in (None, first_pid)


def test_close_ends_the_worker_and_frees_the_buffer(points):
    worker = ProcessLidarWorker(LidarConfig())
    worker(points)
    pid, name = worker.pid, worker._buffer.name
    worker.close()
    assert worker.pid is None
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    with pytest.raises(FileNotFoundError):
        SharedMemory(name)
    worker.close()  # twice is harmless


def test_thread_worker_runs_the_step_in_the_caller(points):
    calls = []

    def step(cloud: np.ndarray, config: LidarConfig) -> LidarResult:
        calls.append(cloud)
        return process_scan(cloud, config)

    worker = ThreadLidarWorker(LidarConfig(), step)
    worker.start()
    assert_same_boxes(worker(points), points)
    assert calls[0] is points
    worker.close()


def test_config_names_the_worker():
    assert isinstance(lidar_worker_for(LidarConfig()), ProcessLidarWorker)
    assert isinstance(lidar_worker_for(LidarConfig(worker="thread")), ThreadLidarWorker)
