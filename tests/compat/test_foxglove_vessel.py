"""A Foxglove client's publish on the command topic moves the simulated vessel.

Real processes: the bridge, the simulator (a light scene) and Node with `@foxglove/ws-protocol`
(js/foxglove_drive.mjs), which reads the odometry as CDR and commands full ahead in CDR.
"""

from __future__ import annotations

import asyncio
import math
import re
from pathlib import Path

import pytest

from schemas.catalogue import TOPICS
from tests.child_process import running
from tests.simulator.sim_processes import light_config, running_bridge, simulator_argv

from .node_runner import run_scenario

pytestmark = pytest.mark.slow

SURGE_N = 4000.0  # the thrusters' full ahead (config/sim.toml [vessel])
DRIVE_S = 4.0


async def test_a_foxglove_publish_on_the_command_topic_moves_the_vessel(tmp_path: Path) -> None:
    config = light_config(tmp_path, resolution_deg=4.0, camera_width_px=80)
    with running_bridge() as (bridge, url), running(simulator_argv(url, config)) as sim:
        await asyncio.to_thread(sim.wait_for_line, re.compile("simulator connected"))
        result = await asyncio.to_thread(
            run_scenario,
            "foxglove_drive.mjs",
            url,
            TOPICS["odom"].name,
            TOPICS["cmd_wrench"].name,
            str(SURGE_N),
            str(DRIVE_S),
        )
        bridge_log = bridge.text()
    assert "Traceback" not in bridge_log, bridge_log
    assert result["before"]["x"] == pytest.approx(0.0, abs=0.05)
    assert result["after"]["x"] > 0.5, result  # m/s, body frame surge
    moved_m = math.dist(
        [result["beforePose"][k] for k in "xy"], [result["afterPose"][k] for k in "xy"]
    )
    assert moved_m > 0.5, result
