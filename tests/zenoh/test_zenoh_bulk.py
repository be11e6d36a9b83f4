"""BulkWriter: while one large put waits, only each topic's newest job stays queued."""

from __future__ import annotations

import threading

from bridge.zenoh.bulk import BulkWriter


def test_a_waiting_put_leaves_only_the_newest_queued_per_topic():
    writer = BulkWriter()
    release = threading.Event()
    started = threading.Event()
    ran: list[str] = []
    done = threading.Event()

    def slow() -> None:
        started.set()
        release.wait(10)
        ran.append("scan 1")

    def job(name: str):
        def run() -> None:
            ran.append(name)
            if name == "scan 4":
                done.set()

        return run

    try:
        writer.put("/scan", slow, 1000)
        assert started.wait(10)
        writer.put("/scan", job("scan 2"), 1000)
        writer.put("/image", job("image 1"), 1000)
        writer.put("/scan", job("scan 3"), 1000)
        writer.put("/scan", job("scan 4"), 1000)
        release.set()
        assert done.wait(10)
    finally:
        writer.close()
    assert ran == ["scan 1", "image 1", "scan 4"]
    assert writer.outbox.dropped["/scan"] == 2
