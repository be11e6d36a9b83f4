"""The process settings every long-running riverbridge process applies."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

from schemas.runtime.process import background_priority, freeze_startup_heap

ROOT = Path(__file__).resolve().parents[2]


def test_freezing_the_start_up_heap_takes_it_out_of_collections() -> None:
    try:
        freeze_startup_heap()
        assert gc.get_freeze_count() > 1000  # the imported modules, classes and registries
    finally:
        gc.unfreeze()


def test_background_threads_run_only_on_idle_cores() -> None:
    seen: dict[str, int] = {}

    def worker() -> None:
        thread_id = threading.get_native_id()
        seen["before"] = os.sched_getscheduler(thread_id)
        background_priority()
        seen["after"] = os.sched_getscheduler(thread_id)
        child = threading.Thread(
            target=lambda: seen.setdefault(
                "child", os.sched_getscheduler(threading.get_native_id())
            )
        )
        child.start()
        child.join()

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen["before"] == os.SCHED_OTHER
    assert seen["after"] == os.SCHED_IDLE
    assert seen["child"] == os.SCHED_IDLE, "threads a background thread starts inherit it"
    assert os.sched_getscheduler(threading.get_native_id()) == os.SCHED_OTHER, (
        "only the calling thread changes"
    )


def test_openblas_is_kept_to_one_thread_for_the_whole_process() -> None:
    # A child process: the limit is process-wide and would leak into the other tests.
    probe = (
        "import json, numpy\n"
        "from threadpoolctl import threadpool_info\n"
        "from schemas.runtime.process import single_threaded_blas\n"
        "single_threaded_blas()\n"
        "a = numpy.ones((300, 3), numpy.float32) @ numpy.eye(3, dtype=numpy.float32)\n"
        "print(json.dumps([p['num_threads'] for p in threadpool_info()"
        " if p['user_api'] == 'blas']))\n"
    )
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "2"}  # what a 2-core machine starts with
    out = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=ROOT,
        env=env,
        check=True,
        capture_output=True,
        text=True,
        timeout=60,
    ).stdout
    blas_threads = json.loads(out)
    assert blas_threads, "numpy's OpenBLAS was found"
    assert set(blas_threads) == {1}
