"""`python -m clients.stack.up_cli` as users run it: three processes, roslibpy, a clean shutdown."""

from __future__ import annotations

import asyncio
import contextlib
import os
import signal
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import roslibpy
from pydantic import SecretStr

from clients import RosbridgeClient
from clients.connection import TransportConfig
from clients.errors import ServiceError
from clients.stack.launcher import NAVIGATION_TOPICS, SIMULATOR_TOPICS
from tests.tls_certificates import make_certificate

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


def test_with_restart_never_killing_the_simulator_makes_up_exit_nonzero_naming_it() -> None:
    with running_up("--restart", "never") as up:
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


IMU_BACK_WITHIN_S = 5.0  # the bound from a kill -9 to IMU flowing again
RESPAWN_WITHIN_S = 1.5  # what up itself adds: noticing the death, 0.25 s backoff, spawning
# The bounds when other work holds every core (see the test): respawn, IMU back.
OVERLOADED_WITHIN_S = (5.0, 20.0)
SETTLE_S = 5.0  # after a restart, before the next kill (a start-up is CPU-heavy)


@dataclass
class Recovery:
    respawned_s: float  # kill -> the restarted process exists
    imu_back_s: float  # kill -> first IMU sample stamped after the kill, at a client


async def imu_recovery_after_kills(up: UpProcess, titles: tuple[str, ...]) -> dict[str, Recovery]:
    """Kill -9 each component in turn; when it was respawned, and when an IMU sample stamped
    after the kill arrived at an ordinary (reconnecting) client."""
    arrivals: list[tuple[float, float]] = []  # (received, header stamp), wall-clock seconds
    recovery: dict[str, Recovery] = {}
    async with RosbridgeClient(up.wait_ready(), encoding="cbor", backoff_max=0.25) as client:
        sub = await client.subscribe("/imu/data", "sensor_msgs/msg/Imu")

        async def collect() -> None:
            async for received in sub:
                stamp = received.msg["header"]["stamp"]
                arrivals.append((time.time(), stamp["sec"] + stamp["nanosec"] / 1e9))

        collector = asyncio.create_task(collect())
        for title in titles:
            await until(lambda: bool(arrivals) and time.time() - arrivals[-1][0] < 0.5, 60.0)
            pid = up.child_pids()[title]
            killed_s = time.time()
            os.kill(pid, signal.SIGKILL)
            await until(lambda t=title, p=pid: up.child_pids()[t] != p, 30.0)
            respawned_s = time.time() - killed_s
            await until(lambda t=killed_s: any(s > t for _, s in arrivals[-50:]), 30.0)
            first = min(r for r, s in arrivals if s > killed_s)
            recovery[title] = Recovery(respawned_s, first - killed_s)
            await asyncio.sleep(SETTLE_S)  # one kill at a time: let the restart settle
        collector.cancel()
    return recovery


async def until(condition, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        await asyncio.sleep(0.02)


def test_a_killed_child_is_restarted_and_imu_flows_again_within_5_s() -> None:
    """Within 5 s holds when the stack has the machine (CI). A simulator's cold start is
    ~2.5 s of imports and scene building on an idle core and two to three times that when
    other work holds both cores (load above cores + 1); then the looser bounds apply."""
    titles = ("navigation", "simulator", "bridge")
    with running_up() as up:
        recovery = asyncio.run(imu_recovery_after_kills(up, titles))
        load = os.getloadavg()[0]
        text = up.text()
        assert up.process.poll() is None, text
        for title in titles:
            assert f"{title} was killed by SIGKILL (exit code -9); restarting it" in text
        code = up.stop(signal.SIGINT)
        assert code == 0, up.text()
        assert_all_gone(up)
    figures = {t: (round(r.respawned_s, 2), round(r.imu_back_s, 2)) for t, r in recovery.items()}
    print(f"(respawned, IMU back) s after a kill -9, load {load:.1f}: {figures}")
    overloaded = load > (os.cpu_count() or 1) + 1
    respawn, back = OVERLOADED_WITHIN_S if overloaded else (RESPAWN_WITHIN_S, IMU_BACK_WITHIN_S)
    assert all(r.respawned_s <= respawn for r in recovery.values()), (figures, load)
    assert all(r.imu_back_s <= back for r in recovery.values()), (figures, load)


def test_a_secured_stack_authenticates_its_parts_over_tls(tmp_path: Path) -> None:
    """up --auth-secret-file --certfile/--keyfile: the simulator and navigation authenticate
    over wss://; a client with the secret and the certificate is served, one without the
    secret is refused."""
    pair = make_certificate(tmp_path)
    secret = tmp_path / "secret.txt"
    secret.write_text("0123456789abcdef\n")
    args = (
        "--auth-secret-file",
        str(secret),
        "--certfile",
        str(pair.certfile),
        "--keyfile",
        str(pair.keyfile),
    )
    with running_up(*args) as up:
        url = up.wait_ready()
        assert url.startswith("wss://127.0.0.1:")

        async def check() -> tuple[dict, dict]:
            trusted = TransportConfig(
                auth_secret=SecretStr("0123456789abcdef"), cafile=pair.certfile
            )
            async with RosbridgeClient(url, encoding="cbor", transport=trusted) as client:
                sub = await client.subscribe("/imu/data", "sensor_msgs/msg/Imu")
                async with asyncio.timeout(60):
                    imu = (await anext(aiter(sub))).msg
            stranger = TransportConfig(auth_secret=None, cafile=pair.certfile)
            async with RosbridgeClient(url, encoding="json", transport=stranger) as client:
                with pytest.raises(ServiceError) as refused:
                    await client.call_service("/rosapi/topics", {}, timeout=20)
            return imu, {"refused": str(refused.value)}

        imu, outcome = asyncio.run(check())
        assert imu["header"]["frame_id"]
        assert "not authenticated" in outcome["refused"]
        assert up.stop(signal.SIGINT) == 0, up.text()
    assert "authentication failed" not in up.text()
