"""The bridge restarts under a running `python -m simulator`: the simulator reconnects by
itself (same process), re-advertises, and every topic flows again, with fresh stamps."""

from __future__ import annotations

import asyncio
import re
import time

import pytest

from clients import RosbridgeClient
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.catalogue import published_by
from tests.child_process import running
from tests.simulator.sim_processes import (
    header_stamp_s,
    light_config,
    running_bridge,
    simulator_argv,
)

pytestmark = pytest.mark.slow

# Every sensor topic the simulator streams (schemas.catalogue): key -> (name, type)
TOPICS = {t.key: t.pair for t in published_by("simulator", "sensor", "realtime")}
DOWN_S = 2.0  # the simulator keeps running (and retrying) this long without a bridge
RESUME_TIMEOUT_S = 20.0


async def first_of_each(url: str, registry, timeout_s: float) -> dict[str, dict]:
    """The first message of every simulator topic (and the latched /tf_static)."""
    topics = {**TOPICS, "tf_static": CATALOGUE["tf_static"].pair}
    async with RosbridgeClient(url, registry=registry, connect_timeout=timeout_s) as listener:
        subs = {name: await listener.subscribe(*topic, maxsize=1) for name, topic in topics.items()}

        async def first(name: str) -> tuple[str, dict | None]:
            try:
                async with asyncio.timeout(timeout_s):
                    return name, (await anext(subs[name])).msg
            except TimeoutError:
                return name, None

        return dict(await asyncio.gather(*(first(name) for name in subs)))


def assert_all_arrived(first: dict[str, dict | None], sim_output: str) -> None:
    missing = sorted(name for name, msg in first.items() if msg is None)
    assert not missing, f"no message on {missing}; simulator output:\n{sim_output}"


async def test_simulator_resumes_every_topic_after_the_bridge_restarts(tmp_path, registry):
    config = light_config(tmp_path, resolution_deg=2.0, camera_width_px=160)
    connected = re.compile(r"simulator connected to")
    with running_bridge() as (first_bridge, url):
        port = url.rsplit(":", 1)[1]
        with running(simulator_argv(url, config)) as sim:
            await asyncio.to_thread(sim.wait_for_line, connected)
            before = await first_of_each(url, registry, RESUME_TIMEOUT_S)
            assert_all_arrived(before, sim.text())

            assert first_bridge.stop() == 0
            lines_at_stop = len(sim.lines)
            await asyncio.sleep(DOWN_S)
            assert sim.process.poll() is None, sim.text()
            restarted_s = time.time()
            with running_bridge(int(port)) as (_, same_url):
                assert same_url == url
                resumed = re.compile(r"simulator connected to .*registrations restored")
                await asyncio.to_thread(sim.wait_for_line, resumed, RESUME_TIMEOUT_S, lines_at_stop)
                after = await first_of_each(url, registry, RESUME_TIMEOUT_S)
            assert sim.process.poll() is None, sim.text()
    assert_all_arrived(after, sim.text())
    for name in TOPICS:  # fresh data, not something replayed from before the restart
        assert header_stamp_s(after[name]) > restarted_s, name
