"""Where the LIDAR step runs: in the calling thread, or in a worker process of its own.

The ground filter and scikit-learn's DBSCAN hold the GIL for stretches of milliseconds per
scan (~30 ms of work at 2 Hz); on a thread of the navigation process every such stretch is
time the event loop that reads the IMU cannot run (DESIGN §4: work that holds the GIL goes to
another process). ``ProcessLidarWorker`` keeps one warm worker process and hands it the points
through a reused shared-memory buffer, so the navigation process pays only a GIL-free copy
(~1 ms for a 2.9 MB scan); the small result (boxes, obstacle labels, step timings) comes back
pickled. The hop costs ~5 ms of LIDAR latency (scan -> boxes) on a 2-core machine.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import select
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.shared_memory import SharedMemory
from typing import Protocol

import numpy as np

from navigation.config import LidarConfig
from navigation.lidar import LidarResult, process_scan
from schemas.runtime.process import background_priority, tune_process

log = logging.getLogger(__name__)

POINT_BYTES = 12  # (x, y, z) float32: the LIDAR step uses no intensity
PARENT_POLL_S = 1.0  # where pidfd is missing: how soon an orphaned worker notices
START_TIMEOUT_S = 120.0  # importing numpy + scikit-learn on a loaded 2-core machine


# The LIDAR step: points (n, 3) float32 -> LidarResult. For a process worker it must pickle
# (a module-level function or an instance of a module-level class).
ScanStep = Callable[[np.ndarray, LidarConfig], LidarResult]


def warm_up_points() -> np.ndarray:
    """A small cloud that takes every step (filter, DBSCAN, boxes): a 2 m cube of points
    20 m ahead above a flat water plane. Returns (n, 4) float32."""
    grid = np.linspace(-1.0, 1.0, 9, dtype=np.float32)
    cube = np.stack(np.meshgrid(grid + 20.0, grid, grid), axis=-1).reshape(-1, 3)
    water = np.stack(
        np.meshgrid(np.linspace(5.0, 40.0, 36), np.linspace(-10.0, 10.0, 21), [-2.0]), axis=-1
    ).reshape(-1, 3)
    xyz = np.concatenate([cube, water]).astype(np.float32)
    return np.column_stack([xyz, np.ones(len(xyz), np.float32)])


class LidarWorker(Protocol):
    """Runs the LIDAR step somewhere; ``start`` and ``close`` bracket its use."""

    def start(self) -> None: ...

    def __call__(self, points: np.ndarray) -> LidarResult: ...

    def close(self) -> None: ...


class ThreadLidarWorker:
    """The LIDAR step in the calling thread (``[lidar] worker = "thread"``)."""

    def __init__(self, config: LidarConfig, step: ScanStep = process_scan) -> None:
        self._config, self._step = config, step

    def start(self) -> None:
        """Nothing to start; the first scan pays scikit-learn's imports."""

    def __call__(self, points: np.ndarray) -> LidarResult:
        return self._step(points, self._config)

    def close(self) -> None:
        """Nothing to release."""


class ProcessLidarWorker:
    """The LIDAR step in one warm worker process (``[lidar] worker = "process"``).

    Calls are serialised (one scan at a time, as the node's single LIDAR thread makes them);
    the caller blocks, without the GIL, until the worker answers. ``forkserver`` children
    start from a clean interpreter: no copied locks, threads or sockets of the event loop.
    """

    def __init__(self, config: LidarConfig, step: ScanStep = process_scan) -> None:
        self._config, self._step = config, step
        self._lock = threading.Lock()
        self._pool: ProcessPoolExecutor | None = None
        self._buffer: SharedMemory | None = None
        self.pid: int | None = None  # the worker process, once started

    def start(self) -> None:
        """Start the worker process and run one small scan through it, so that the
        imports and scikit-learn's first-call set-up are paid before the first real scan."""
        with self._lock:
            self._ensure_started()

    def __call__(self, points: np.ndarray) -> LidarResult:
        """points : (n, >=3) float32, any strides (a view of the message's bytes)."""
        with self._lock:
            pool = self._ensure_started()
            buffer = self._buffer_for(points.shape[0] * POINT_BYTES)
            count = points.shape[0]
            staged = np.ndarray((count, 3), np.float32, buffer=buffer.buf)
            np.copyto(staged, points[:, :3], casting="same_kind")  # releases the GIL
            del staged  # no view may outlive the buffer (SharedMemory.close refuses)
            future = pool.submit(_run_shared, self._step, buffer.name, count, self._config)
            try:
                return future.result()
            except BrokenProcessPool:
                # The worker died (killed, out of memory): this scan fails, the next one
                # starts a fresh worker.
                pool.shutdown(wait=False, cancel_futures=True)
                self._pool, self.pid = None, None
                raise

    def close(self) -> None:
        """Stop the worker process (waits for a scan in progress) and free the buffer."""
        with self._lock:
            if self._pool is not None:
                self._pool.shutdown(wait=True, cancel_futures=True)
                self._pool, self.pid = None, None
            if self._buffer is not None:
                self._buffer.close()
                self._buffer.unlink()
                self._buffer = None

    def _ensure_started(self) -> ProcessPoolExecutor:
        """The running pool; starts and warms up a new one if there is none (lock held)."""
        if self._pool is not None:
            return self._pool
        context = multiprocessing.get_context("forkserver")
        pool = ProcessPoolExecutor(
            1, mp_context=context, initializer=_init_worker, initargs=(os.getpid(),)
        )
        started = time.perf_counter()
        try:
            self.pid = pool.submit(_warm_up, self._config).result(START_TIMEOUT_S)
        except BaseException:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
        log.info("LIDAR worker process %d ready in %.1f s", self.pid, time.perf_counter() - started)
        self._pool = pool
        return pool

    def _buffer_for(self, size_bytes: int) -> SharedMemory:
        """The shared input buffer, replaced by a larger one when a scan outgrows it."""
        if self._buffer is None or self._buffer.size < size_bytes:
            if self._buffer is not None:
                self._buffer.close()
                self._buffer.unlink()
            # 25 % headroom: scan sizes vary with the scene (returns beyond range drop out)
            self._buffer = SharedMemory(create=True, size=max(size_bytes * 5 // 4, 1))
        return self._buffer


def lidar_worker_for(config: LidarConfig) -> LidarWorker:
    """The worker that ``config.worker`` names, not yet started."""
    if config.worker == "process":
        return ProcessLidarWorker(config)
    return ThreadLidarWorker(config)


def _init_worker(parent_pid: int) -> None:
    """Worker process set-up: background priority like the node's worker threads (on 2 cores
    the clustering must leave the event loops of all three processes a core at once); SIGINT
    (a terminal's Ctrl-C reaches the whole process group) is the parent's to handle, which then
    stops this worker cleanly; the start-up settings of every riverbridge process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    background_priority()
    tune_process()
    _exit_with(parent_pid)


def _exit_with(parent_pid: int) -> None:
    """End this worker as soon as the navigation process ends without stopping it (SIGKILL,
    a crash). Otherwise it would wait forever on its task queue, and keep the forkserver
    (which only exits once every process it started is gone) and the parent's stdout alive.
    Linux's pidfd wakes a watcher thread at the parent's exit; elsewhere it polls."""
    try:
        parent = os.pidfd_open(parent_pid)
    except ProcessLookupError:
        os._exit(1)
    except (AttributeError, OSError):
        parent = None

    def watch() -> None:
        if parent is not None:
            select.select([parent], [], [])
        else:
            while _alive(parent_pid):
                time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="lidar-parent-watch", daemon=True).start()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _warm_up(config: LidarConfig) -> int:
    """In the worker: one small scan through every step; returns the worker's pid."""
    process_scan(warm_up_points(), config)
    return os.getpid()


def _run_shared(step: ScanStep, name: str, count: int, config: LidarConfig) -> LidarResult:
    """In the worker: copy the points out of the shared buffer, then run ``step``.

    The private copy (~1 ms, on the worker's own GIL) lets the buffer be detached at once,
    whatever the step raises or keeps.
    """
    buffer = SharedMemory(name)
    try:
        points = np.array(np.ndarray((count, 3), np.float32, buffer=buffer.buf))
    finally:
        buffer.close()
    return step(points, config)
