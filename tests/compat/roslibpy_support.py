"""Helpers for driving the real roslibpy client from tests.

roslibpy's default transport runs Autobahn on the Twisted reactor in a daemon thread, and a
Twisted reactor can be started only once per process. So every test opens its own `Ros`
connections on that one shared reactor and closes them when done; the reactor itself is left
running (stopping it would make roslibpy unusable for the rest of the pytest session).
roslibpy reports protocol trouble only through logging (an unhandled `status` op, a binary
frame, an unknown service-response id), so a log trap is how tests see it.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import roslibpy

# roslibpy's blocking rosapi helpers default to 3 s: too short on a loaded 2-core machine.
ROSAPI_TIMEOUT_S = 20.0
CONNECT_TIMEOUT_S = 30.0
WAIT_TIMEOUT_S = 20.0

# Loggers roslibpy's twisted transport writes to (Twisted's log is bridged into `twisted`).
TRAPPED_LOGGERS = ("roslibpy", "twisted", "autobahn")


class LogTrap(logging.Handler):
    """Collects WARNING-and-above records from roslibpy and its transport."""

    def __init__(self) -> None:
        super().__init__(level=logging.WARNING)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.split(".")[0] in TRAPPED_LOGGERS:
            self.records.append(record)

    def lines(self) -> list[str]:
        return [f"{record.name}: {self.format(record)}" for record in self.records]

    def errors(self) -> list[str]:
        """ERROR/CRITICAL lines: what roslibpy logs for an op it cannot handle."""
        return [
            f"{record.name}: {self.format(record)}"
            for record in self.records
            if record.levelno >= logging.ERROR
        ]


@contextlib.contextmanager
def trapped_roslibpy_logs() -> Iterator[LogTrap]:
    trap = LogTrap()
    trap.setFormatter(logging.Formatter("%(levelname)s %(message)s"))
    root = logging.getLogger()
    root.addHandler(trap)
    try:
        yield trap
    finally:
        root.removeHandler(trap)


def connect(host: str, port: int) -> roslibpy.Ros:
    """Open a roslibpy connection with its default transport and wait until it is ready."""
    roslibpy.set_rosapi_timeout(ROSAPI_TIMEOUT_S)
    ros = roslibpy.Ros(host, port)
    ros.run(timeout=CONNECT_TIMEOUT_S)
    assert ros.is_connected, f"roslibpy could not connect to ws://{host}:{port}"
    return ros


def close(ros: roslibpy.Ros) -> None:
    """Close one connection for good, leaving the shared reactor running for the next test.

    A connection the bridge dropped first would otherwise keep retrying in the background
    (ReconnectingClientFactory), so its retries are stopped too.
    """
    with contextlib.suppress(Exception):
        ros.close(timeout=CONNECT_TIMEOUT_S)
    stop_trying = getattr(ros.factory, "stopTrying", None)
    if stop_trying is not None:
        from twisted.internet import reactor

        reactor.callFromThread(stop_trying)
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while ros.is_connected and time.monotonic() < deadline:
        time.sleep(0.05)


@contextlib.contextmanager
def connected(host: str, port: int) -> Iterator[roslibpy.Ros]:
    """A roslibpy connection for the `with` block."""
    ros = connect(host, port)
    try:
        yield ros
    finally:
        close(ros)


@dataclass(eq=False)  # hashable by identity: roslibpy keys its listeners by callback
class Inbox:
    """Thread-safe collector for roslibpy callbacks (they run on the reactor thread)."""

    items: list[Any] = field(default_factory=list)
    _changed: threading.Condition = field(default_factory=threading.Condition)

    def __call__(self, item: Any) -> None:
        with self._changed:
            self.items.append(item)
            self._changed.notify_all()

    def wait_for(self, count: int, timeout_s: float = WAIT_TIMEOUT_S) -> list[Any]:
        with self._changed:
            self._changed.wait_for(lambda: len(self.items) >= count, timeout_s)
            return list(self.items)

    def expect(self, count: int, timeout_s: float = WAIT_TIMEOUT_S) -> list[Any]:
        """Like wait_for, but fails the test when fewer than `count` items arrived."""
        items = self.wait_for(count, timeout_s)
        assert len(items) >= count, f"expected {count} callbacks within {timeout_s} s: {items}"
        return items

    def snapshot(self) -> list[Any]:
        with self._changed:
            return list(self.items)


@dataclass(frozen=True)
class CallOutcome:
    """What a non-blocking roslibpy service call delivered: callback or errback, and its value."""

    succeeded: bool
    value: Any


def call_service(
    ros: roslibpy.Ros, name: str, args: dict[str, Any], timeout_s: float = WAIT_TIMEOUT_S
) -> CallOutcome:
    """Call through `roslibpy.Service.call` with callback + errback, bounded by `timeout_s`.

    roslibpy's own blocking form has no timeout for some rosapi helpers; this keeps a broken
    bridge from hanging the suite while using exactly roslibpy's request and response path.
    """
    done = threading.Event()
    box: list[CallOutcome] = []

    def finish(succeeded: bool) -> Callable[[Any], None]:
        def record(value: Any) -> None:
            box.append(CallOutcome(succeeded, value))
            done.set()

        return record

    service = roslibpy.Service(ros, name, "")
    service.call(roslibpy.ServiceRequest(args), finish(True), finish(False))
    assert done.wait(timeout_s), f"roslibpy call to {name} got no answer within {timeout_s} s"
    return box[0]


def barrier(ros: roslibpy.Ros) -> None:
    """Round-trip a rosapi call: the bridge handles a connection's ops in order, so every op
    this connection sent before (subscribe, advertise) has been applied once it returns."""
    outcome = call_service(ros, "/rosapi/get_time", {})
    assert outcome.succeeded, f"/rosapi/get_time failed: {outcome.value}"
