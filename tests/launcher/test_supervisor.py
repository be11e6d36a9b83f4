"""The supervisor with real components: the bridge and the navigation service as processes.

These run without the simulator, so the supervision paths are exercised even where the
simulator's command line is not available. Navigation publishes its obstacle map on a timer
from start-up, so "it works" means more than a map arriving: the test sends a radar echo as
the simulator would and waits for the map to mark it (tests/launcher/sensor_data.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import logging
import os
import re
import signal
import socket
import urllib.request
from collections.abc import Iterator
from dataclasses import replace

import pytest

from clients.node.child import Component
from clients.node.output import PrefixedLogHandler, PrefixedOutput
from clients.stack.launcher import LaunchConfig, Supervisor, stack_components
from tests.child_process import repo_env

from .processes import kill_leftovers, wait_gone
from .sensor_data import map_marking_an_echo

pytestmark = pytest.mark.slow

CONFIG = LaunchConfig(port=0, startup_timeout_s=150.0, stop_timeout_s=20.0)


@pytest.fixture
def output() -> Iterator[io.StringIO]:
    """Everything the supervisor and its children wrote, prefixed."""
    stream = io.StringIO()
    handler = PrefixedLogHandler(PrefixedOutput(stream))
    logger = logging.getLogger("clients.stack.launcher")
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    yield stream
    logger.removeHandler(handler)


def bridge_and_navigation(config: LaunchConfig = CONFIG) -> list[Component]:
    bridge, _, nav = stack_components(config)
    return [bridge, nav]


class Harness:
    """A supervisor running as a task, with its ready URL and a stop switch."""

    def __init__(
        self, components: list[Component], config: LaunchConfig, stream: io.StringIO
    ) -> None:
        self.stop = asyncio.Event()
        self.ready: asyncio.Future[str] = asyncio.get_running_loop().create_future()
        self.supervisor = Supervisor(
            components,
            config,
            PrefixedOutput(stream),
            env=repo_env(),
            on_ready=self.ready.set_result,
        )
        self.task = asyncio.create_task(self.supervisor.run(self.stop))

    def pids(self) -> list[int]:
        return [child.pid for child in self.supervisor.children]

    async def finish(self, timeout_s: float = 120.0) -> int:
        try:
            return await asyncio.wait_for(self.task, timeout_s)
        finally:
            kill_leftovers(self.pids())


async def test_runs_until_stopped_then_exits_0_leaving_no_process(output: io.StringIO) -> None:
    harness = Harness(bridge_and_navigation(), CONFIG, output)
    url = await asyncio.wait_for(asyncio.shield(harness.ready), 180.0)
    await map_marking_an_echo(url)
    harness.stop.set()
    assert await harness.finish() == 0, output.getvalue()
    assert wait_gone(harness.pids()) == []
    text = output.getvalue()
    assert "[bridge] " in text and "[nav]    " in text and "navigation ready" in text


async def test_a_dying_component_stops_the_rest_and_is_named(output: io.StringIO) -> None:
    config = CONFIG.model_copy(update={"restart": "never"})
    harness = Harness(bridge_and_navigation(config), config, output)
    await asyncio.wait_for(asyncio.shield(harness.ready), 180.0)
    nav_pid = harness.supervisor.children[1].pid
    os.kill(nav_pid, signal.SIGKILL)
    assert await harness.finish() == 1
    assert "navigation was killed by SIGKILL (exit code -9)" in output.getvalue()
    assert wait_gone(harness.pids()) == []


async def test_a_component_that_never_gets_ready_times_out_naming_the_topic(
    output: io.StringIO,
) -> None:
    config = CONFIG.model_copy(update={"startup_timeout_s": 20.0})
    bridge, nav = bridge_and_navigation(config)
    never = replace(nav, topics=(*nav.topics, "/never/published"))
    harness = Harness([bridge, never], config, output)
    assert await harness.finish() == 1
    text = output.getvalue()
    assert "navigation not ready within 20 s" in text
    assert "no publisher on /never/published" in text
    assert not harness.ready.done()
    assert wait_gone(harness.pids()) == []


async def test_a_bridge_that_cannot_listen_is_reported(output: io.StringIO) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        config = CONFIG.model_copy(update={"port": taken.getsockname()[1]})
        harness = Harness(bridge_and_navigation(config), config, output)
        assert await harness.finish() == 1
    assert "bridge exited with code" in output.getvalue()
    assert len(harness.pids()) == 1  # navigation was never started


async def restart_counts_in_metrics(
    url: str, wanted: dict[str, int], timeout_s: float = 60.0
) -> str:
    """GET /metrics until it shows `wanted` restarts per component; the page."""
    metrics_url = url.replace("ws://", "http://") + "/metrics"
    deadline = asyncio.get_running_loop().time() + timeout_s
    while True:
        with contextlib.suppress(OSError):
            page = await asyncio.to_thread(
                lambda: urllib.request.urlopen(metrics_url, timeout=5).read().decode()
            )
            if all(
                f'riverbridge_component_restarts_total{{component="{c}"}} {float(n)}' in page
                for c, n in wanted.items()
            ):
                return page
        assert asyncio.get_running_loop().time() < deadline, f"no {wanted} in /metrics"
        await asyncio.sleep(0.5)


async def test_killed_components_are_restarted_counted_and_work(output: io.StringIO) -> None:
    harness = Harness(bridge_and_navigation(), CONFIG, output)
    url = await asyncio.wait_for(asyncio.shield(harness.ready), 180.0)
    for title in ("navigation", "bridge"):
        [child] = [c for c in harness.supervisor.children if c.component.title == title]
        os.kill(child.pid, signal.SIGKILL)
        await restart_counts_in_metrics(url, {title: 1})
    await map_marking_an_echo(url)  # the restarted bridge carries sensor data to navigation
    await restart_counts_in_metrics(url, {"bridge": 1, "navigation": 1})
    harness.stop.set()
    assert await harness.finish() == 0, output.getvalue()
    text = output.getvalue()
    assert (
        "navigation was killed by SIGKILL (exit code -9); restarting it in 0.25 s (restart 1)"
        in text
    )
    assert "bridge was killed by SIGKILL (exit code -9); restarting it in 0.25 s" in text
    assert wait_gone(harness.pids()) == []


async def _respawned(harness: Harness, title: str, old_pid: int) -> int:
    """The pid of `title` once the supervisor has started it again."""
    while True:
        pids = [c.pid for c in harness.supervisor.children if c.component.title == title]
        if pids and pids[0] != old_pid:
            return pids[0]
        await asyncio.sleep(0.005)


@pytest.mark.parametrize("when", ["waiting to restart", "just restarted"])
async def test_a_stop_during_a_restart_exits_0_leaving_no_process(
    output: io.StringIO, when: str
) -> None:
    """A user's stop is a clean stop even while a component is being restarted: during the
    backoff delay, or while the new process is still starting (its imports, before it handles
    SIGINT itself)."""
    harness = Harness(bridge_and_navigation(), CONFIG, output)
    await asyncio.wait_for(asyncio.shield(harness.ready), 180.0)
    [nav] = [c for c in harness.supervisor.children if c.component.title == "navigation"]
    os.kill(nav.pid, signal.SIGKILL)
    if when == "waiting to restart":
        while "restarting it in" not in output.getvalue():
            await asyncio.sleep(0.005)
    else:
        await asyncio.wait_for(_respawned(harness, "navigation", nav.pid), 30.0)
    harness.stop.set()
    assert await harness.finish() == 0, output.getvalue()
    assert wait_gone(harness.pids()) == []
    if when == "just restarted":
        # SIGINT, or exit 1 when it lands inside numpy's C import (an ImportError)
        assert re.search(
            r"navigation stopped while starting \((SIGINT|exit code 1)\)", output.getvalue()
        )


async def test_a_serving_component_that_dies_of_the_stop_signal_is_an_unclean_stop(
    output: io.StringIO,
) -> None:
    """Only a component still starting may end by the SIGINT that stops it: one that serves
    must handle it (exit 0), or `up` says so and exits 1."""
    bridge, _ = bridge_and_navigation()
    harness = Harness(
        [bridge, Component("raw", "raw", "tests.launcher.no_sigint_handler", ())], CONFIG, output
    )
    await asyncio.wait_for(asyncio.shield(harness.ready), 180.0)
    harness.stop.set()
    assert await harness.finish() == 1
    assert "unclean shutdown: raw was killed by SIGINT (exit code -2)" in output.getvalue()
    assert wait_gone(harness.pids()) == []
