"""Process and thread settings every long-running riverbridge process applies (DESIGN §4).

They live at the bottom layer because the bridge, the simulator and the navigation service all
need them and the bridge may not import the client side.
"""

from __future__ import annotations

import contextlib
import gc
import os
import sys
import threading
from collections.abc import Mapping

from threadpoolctl import threadpool_limits

# glibc malloc tuning for 4 MB sensor buffers: fresh mmap'd buffers cost ~3 ms of page faults
# per scan (performance-measurements.md, page-fault note); these keep them on the heap.
MALLOC_ENV: Mapping[str, str] = {
    "MALLOC_MMAP_THRESHOLD_": "268435456",
    "MALLOC_TRIM_THRESHOLD_": "1073741824",
    "MALLOC_TOP_PAD_": "67108864",
}

# Heavy work (ray casts, clustering, big encodes) runs on threads that only get a core when no
# normal thread wants one (SCHED_IDLE): on 2 cores a scan's work occupies both, and an IMU sample
# must not wait behind it. A nice value is not enough under Linux's EEVDF scheduler: a waking
# event loop still waits for the running nice-5 (or even nice-19) thread's slice, while it
# preempts a SCHED_IDLE thread at once. IMU samples above 5 ms on their way through all three
# processes (`riverbridge report`, CBOR, 20 s, 1000 samples): nice 5: 62 and 63; nice 19: 45
# and 42; SCHED_IDLE: 20 and 5. Where SCHED_IDLE is missing the thread falls back to nice 5.
BACKGROUND_NICE = 5


def background_priority() -> None:
    """Thread initializer: run this thread (and the threads it starts) only on otherwise idle
    cores; on systems without SCHED_IDLE, at nice `BACKGROUND_NICE`. Linux applies both per
    thread; elsewhere this is a no-op."""
    thread_id = threading.get_native_id()
    try:
        os.sched_setscheduler(thread_id, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        with contextlib.suppress(OSError, AttributeError):
            os.setpriority(os.PRIO_PROCESS, thread_id, BACKGROUND_NICE)


def freeze_startup_heap() -> None:
    """Exempt every object alive now from garbage collection; call once start-up is done.

    A full collection traverses every tracked object while holding the GIL. Over the start-up
    heap of numpy, scikit-learn, OpenCV, rosbags and pydantic (60k-120k objects) that took
    32-72 ms here, and each one stalled the event loop and every IMU sample queued on it
    (`riverbridge report`: navigation's bridge -> navigation hop max 72 -> 5-11 ms after the
    freeze). Long-lived start-up objects never become garbage, so nothing is lost.
    """
    gc.collect()
    gc.freeze()


def single_threaded_blas() -> None:
    """Keep OpenBLAS (numpy's matmul) on the calling thread, process-wide.

    Our own threads already split the heavy work across the 2 cores. OpenBLAS's worker threads
    spin for a while after every call, even a 3-column matmul, and take those cores from Embree
    and the event loops: rotating the LIDAR rays just before a scan made its ray cast take 36
    instead of 19 ms. `python -m benchmarks.simulator --quick`: LIDAR scan median 32 -> 25.5 ms,
    camera frame 43.5 -> 32 ms. The single-threaded matmul of 345,600 rays costs 0.4 ms more.
    """
    threadpool_limits(limits=1, user_api="blas")


# How long a thread may hold the GIL while another waits for it (CPython's default: 5 ms).
# Decoding and validating a large nested message (400 radar detections: 6 ms) runs on a worker
# thread so the event loop stays free; with the default interval the loop would still wait up
# to 5 ms for the GIL whenever a small message arrives meanwhile.
GIL_SWITCH_INTERVAL_S = 0.0005


def tune_process() -> None:
    """Start-up settings of every riverbridge process: OpenBLAS on one thread and a short GIL
    switch interval. Call once, early; `freeze_startup_heap` follows when start-up is done."""
    single_threaded_blas()
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
