"""The process settings every long-running riverbridge process applies."""

from __future__ import annotations

import gc
import os
import threading

from schemas.process_tuning import BACKGROUND_NICE, background_priority, freeze_startup_heap


def test_freezing_the_start_up_heap_takes_it_out_of_collections() -> None:
    try:
        freeze_startup_heap()
        assert gc.get_freeze_count() > 1000  # the imported modules, classes and registries
    finally:
        gc.unfreeze()


def test_background_threads_run_at_a_lower_priority() -> None:
    seen: dict[str, int] = {}

    def worker() -> None:
        before = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
        background_priority()
        seen["before"] = before
        seen["after"] = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen["after"] == BACKGROUND_NICE
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == seen["before"], (
        "only the calling thread changes")
