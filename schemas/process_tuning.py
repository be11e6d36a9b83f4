"""Process and thread settings every long-running riverbridge process applies (DESIGN §4).

They live at the bottom layer because the bridge, the simulator and the navigation service all
need them and the bridge may not import the client side.
"""

from __future__ import annotations

import contextlib
import gc
import os
import threading

from threadpoolctl import threadpool_limits

# Heavy work (ray casts, clustering, big encodes) runs at a lower CPU priority than the event
# loop that carries the small messages: on 2 cores a scan's work occupies both, and an IMU sample
# must not wait a scheduler slice behind it. Threads these workers start inherit the value; 5
# leaves them ~1/3 of a contended core. Measured with `riverbridge report` on an idle 2-core
# machine: LIDAR CBOR transport p99 24 -> 15 ms, IMU p99 15 -> 9 ms.
BACKGROUND_NICE = 5


def background_priority() -> None:
    """Thread initializer: lower this thread's scheduling priority (Linux; no-op elsewhere)."""
    with contextlib.suppress(OSError, AttributeError):
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), BACKGROUND_NICE)


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
    instead of 19 ms. `python benchmarks/simulator.py --quick`: LIDAR scan median 32 -> 25.5 ms,
    camera frame 43.5 -> 32 ms. The single-threaded matmul of 345,600 rays costs 0.4 ms more.
    """
    threadpool_limits(limits=1, user_api="blas")
