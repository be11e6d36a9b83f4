"""The README's client examples, run against a real `riverbridge up` stack."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.child_process import REPO_ROOT

from .test_up_stack import running_up

pytestmark = pytest.mark.slow

EXAMPLES = REPO_ROOT / "clients" / "examples"
NODE_MODULES = REPO_ROOT / "tests" / "compat" / "js" / "node_modules"


def test_roslibpy_example_prints_imu_and_obstacle_map() -> None:
    with running_up() as up:
        result = subprocess.run(
            [
                sys.executable,
                str(EXAMPLES / "roslibpy_listener.py"),
                "--port",
                str(up.port()),
                "--count",
                "2",
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "/imu/data: yaw rate" in result.stdout
    assert "/nav/obstacle_map: " in result.stdout and " occupied" in result.stdout


def test_roslibjs_example_decodes_a_cbor_scan(tmp_path: Path) -> None:
    node = shutil.which("node")
    assert node, "Node.js is missing: run scripts/setup.sh"
    assert (NODE_MODULES / "roslib").is_dir(), "roslib is missing: run scripts/setup.sh"
    # ES modules resolve packages from the script's folder, so run a copy next to them.
    (tmp_path / "node_modules").symlink_to(NODE_MODULES, target_is_directory=True)
    script = shutil.copy(EXAMPLES / "roslibjs_listener.mjs", tmp_path)
    with running_up() as up:
        result = subprocess.run(
            [node, str(script), f"ws://127.0.0.1:{up.port()}", "60000"],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "/lidar/points: " in result.stdout and "nearest return" in result.stdout
    points = int(result.stdout.split("/lidar/points: ")[1].split(" points")[0])
    assert points > 10_000, result.stdout
    assert "/nav/boxes: " in result.stdout
