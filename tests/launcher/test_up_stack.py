"""`python -m clients.up_cli` as users run it: three processes, a roslibpy client, shutdown.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import roslibpy

from clients.launcher import NAVIGATION_TOPICS, SIMULATOR_TOPICS

from .processes import UpProcess, kill_leftovers, wait_gone

pytestmark = pytest.mark.slow

ROSLIBPY_TIMEOUT_S = 60.0
TITLES = ("bridge", "simulator", "navigation")


@contextlib.contextmanager
def running_up(*args: str) -> Iterator[UpProcess]:
    """`up` on a free port, waited on until ready; anything left is killed afterwards."""
    up = UpProcess(*args)
    try:
        up.wait_ready()
        assert set(up.child_pids()) == set(TITLES), up.text()
        yield up
    finally:
        up.kill_session()
        kill_leftovers(list(up.child_pids().values()))


@contextlib.contextmanager
def roslibpy_connection(port: int) -> Iterator[roslibpy.Ros]:
    roslibpy.set_rosapi_timeout(ROSLIBPY_TIMEOUT_S)
    ros = roslibpy.Ros("127.0.0.1", port)
    ros.run(timeout=ROSLIBPY_TIMEOUT_S)
    try:
        yield ros
    finally:
        with contextlib.suppress(Exception):
            ros.close(timeout=ROSLIBPY_TIMEOUT_S)


def first_message(ros: roslibpy.Ros, topic: str, type_name: str) -> dict[str, Any]:
    """The first message roslibpy delivers on ``topic`` (AssertionError after a minute)."""
    got: list[dict[str, Any]] = []
    arrived = threading.Event()

    def keep(msg: dict[str, Any]) -> None:
        got.append(msg)
        arrived.set()

    listener = roslibpy.Topic(ros, topic, type_name)
    listener.subscribe(keep)
    try:
        assert arrived.wait(ROSLIBPY_TIMEOUT_S), f"roslibpy received nothing on {topic}"
    finally:
        listener.unsubscribe()
    return got[0]


def assert_all_gone(up: UpProcess) -> None:
    pids = up.child_pids()
    alive = wait_gone(list(pids.values()))
    assert alive == [], f"orphans left: {alive} of {pids}\n{up.text()}"


def test_serves_every_topic_to_roslibpy_and_stops_cleanly_on_sigint() -> None:
    with running_up("--encoding", "cbor") as up:
        with roslibpy_connection(up.port()) as ros:
            topics = ros.get_topics()
            missing = set(SIMULATOR_TOPICS + NAVIGATION_TOPICS) - set(topics)
            assert not missing, f"/rosapi/topics lacks {sorted(missing)}: {topics}"
            imu = first_message(ros, "/imu/data", "sensor_msgs/msg/Imu")
            grid = first_message(ros, "/nav/obstacle_map", "nav_msgs/msg/OccupancyGrid")
        assert imu["header"]["frame_id"]
        assert grid["info"]["width"] * grid["info"]["height"] == len(grid["data"]) > 0
        code = up.stop(signal.SIGINT)
        text = up.text()
        assert code == 0, text
        assert_all_gone(up)
    for prefix in ("[bridge] ", "[sim]    ", "[nav]    "):
        assert prefix in text, f"no {prefix!r} lines:\n{text}"
    assert "\x1b[" not in text  # not a TTY: no colour codes


def test_sigterm_stops_cleanly_too() -> None:
    with running_up("--encoding", "json") as up:
        assert up.stop(signal.SIGTERM) == 0, up.text()
        assert_all_gone(up)


def test_killing_the_simulator_makes_up_exit_nonzero_naming_it() -> None:
    with running_up() as up:
        os.kill(up.child_pids()["simulator"], signal.SIGKILL)
        code = up.process.wait(timeout=120)
        assert code != 0
        assert "simulator was killed by SIGKILL (exit code -9)" in up.text()
        assert_all_gone(up)


def test_a_killed_up_leaves_nothing_running() -> None:
    with running_up() as up:
        up.process.kill()
        up.process.wait(timeout=60)
        assert_all_gone(up)
