"""Fixtures shared by the compatibility tests: a fresh `python -m bridge` per test."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest
import roslibpy

from . import roslibpy_support as rp
from .bridge_process import BridgeEndpoint, running_bridge


def assert_bridge_survived(endpoint: BridgeEndpoint) -> None:
    """The bridge must still be running and must not have logged an unhandled exception."""
    log = endpoint.log.text()
    assert endpoint.process.poll() is None, f"bridge exited during the test:\n{log}"
    assert "Traceback" not in log, f"bridge logged a traceback:\n{log}"


@pytest.fixture
def bridge() -> Iterator[BridgeEndpoint]:
    """A bridge process of its own for one test, stopped (SIGINT, then kill) afterwards."""
    with running_bridge() as endpoint:
        yield endpoint
        assert_bridge_survived(endpoint)


@pytest.fixture(scope="module")
def module_bridge() -> Iterator[BridgeEndpoint]:
    """One bridge process shared by a module whose tests use disjoint names."""
    with running_bridge() as endpoint:
        yield endpoint
        assert_bridge_survived(endpoint)


@pytest.fixture
def log_trap() -> Iterator[rp.LogTrap]:
    """Fails the test when roslibpy logged an error (unhandled op, binary frame, ...)."""
    with rp.trapped_roslibpy_logs() as trap:
        yield trap
        assert not trap.errors(), "roslibpy logged errors:\n" + "\n".join(trap.errors())


@pytest.fixture
def open_ros(bridge: BridgeEndpoint, log_trap: rp.LogTrap) -> Iterator[Callable[[], roslibpy.Ros]]:
    """Opens as many roslibpy connections to the test's bridge as a test needs."""
    opened: list[roslibpy.Ros] = []

    def open_one() -> roslibpy.Ros:
        ros = rp.connect(bridge.host, bridge.port)
        opened.append(ros)
        return ros

    yield open_one
    for ros in opened:
        rp.close(ros)
