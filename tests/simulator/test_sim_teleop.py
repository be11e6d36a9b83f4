"""Keyboard teleop: the key state machine, the CLI's publishing, and steering a real simulator
from a pseudo-terminal."""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import re
import subprocess
import sys
import termios
import time

import pytest

from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from clients import RosbridgeClient
from schemas.catalogue import TOPICS
from simulator.config import VesselConfig
from simulator.teleop import Action, KeyDecoder, TeleopCommand, TeleopScale
from simulator.teleop_cli import main
from tests.child_process import REPO_ROOT, running
from tests.simulator.sim_processes import light_config, running_bridge, simulator_argv

SCALE = TeleopScale(max_surge_force_n=4000.0, max_yaw_moment_nm=6000.0, steps=10)


# ------------------------------------------------------------------ key decoding
def test_arrows_wasd_space_and_quit_decode():
    keys = b"\x1b[A\x1b[B\x1b[C\x1b[D\x1bOA wWsSaAdDqQ\x03\x04"
    assert KeyDecoder().feed(keys) == [
        Action.SURGE_UP,
        Action.SURGE_DOWN,
        Action.YAW_RIGHT,
        Action.YAW_LEFT,
        Action.SURGE_UP,
        Action.STOP,
        Action.SURGE_UP,
        Action.SURGE_UP,
        Action.SURGE_DOWN,
        Action.SURGE_DOWN,
        Action.YAW_LEFT,
        Action.YAW_LEFT,
        Action.YAW_RIGHT,
        Action.YAW_RIGHT,
        Action.QUIT,
        Action.QUIT,
        Action.QUIT,
        Action.QUIT,
    ]


def test_escape_sequence_split_across_reads_is_kept():
    decoder = KeyDecoder()
    assert decoder.feed(b"w\x1b") == [Action.SURGE_UP]
    assert decoder.feed(b"[") == []
    assert decoder.feed(b"Dd") == [Action.YAW_LEFT, Action.YAW_RIGHT]


def test_unknown_keys_and_sequences_are_skipped():
    assert KeyDecoder().feed(b"xz1\x1b[Z\x1b[5~\x1bw\n") == [Action.SURGE_UP]


# ------------------------------------------------------------------ command state
def press(*actions: Action, start: TeleopCommand | None = None) -> TeleopCommand:
    command = start or TeleopCommand()
    for action in actions:
        command = command.apply(action, SCALE)
    return command


def test_steps_raise_and_lower_surge_and_yaw():
    command = press(Action.SURGE_UP, Action.SURGE_UP, Action.SURGE_UP, Action.YAW_RIGHT)
    assert command.wrench(SCALE) == {
        "force": {"x": 1200.0, "y": 0.0, "z": 0.0},
        "torque": {"x": 0.0, "y": 0.0, "z": -600.0},
    }
    back = press(
        Action.SURGE_DOWN, Action.SURGE_DOWN, Action.SURGE_DOWN, Action.YAW_LEFT, start=command
    )
    assert back == TeleopCommand()
    astern = press(Action.SURGE_DOWN, Action.YAW_LEFT, Action.YAW_LEFT)
    assert astern.surge_force_n(SCALE) == -400.0 and astern.yaw_moment_nm(SCALE) == 1200.0


def test_commands_stay_within_the_vessel_limits():
    full = press(*[Action.SURGE_UP] * 25, *[Action.YAW_LEFT] * 25)
    assert full.surge_force_n(SCALE) == 4000.0 and full.yaw_moment_nm(SCALE) == 6000.0
    reverse = press(*[Action.SURGE_DOWN] * 25, *[Action.YAW_RIGHT] * 25)
    assert reverse.surge_force_n(SCALE) == -4000.0 and reverse.yaw_moment_nm(SCALE) == -6000.0
    # one press back from the clip is one step below the limit, not several
    assert press(Action.SURGE_DOWN, start=full).surge_force_n(SCALE) == 3600.0


def test_space_zeroes_and_quit_leaves_the_command():
    moving = press(Action.SURGE_UP, Action.YAW_LEFT)
    assert press(Action.STOP, start=moving) == TeleopCommand()
    assert press(Action.QUIT, start=moving) == moving


def test_scale_follows_the_vessel_config_and_the_status_line():
    scale = TeleopScale.of(VesselConfig(max_surge_force_n=1000.0, max_yaw_moment_nm=500.0), 4)
    assert (scale.surge_step_n, scale.yaw_step_nm) == (250.0, 125.0)
    default = TeleopScale()
    assert default.max_surge_force_n == VesselConfig().max_surge_force_n
    line = press(Action.SURGE_UP, Action.YAW_RIGHT).status(SCALE)
    assert "+400 N" in line and "-600 N m" in line and "\n" not in line


# ------------------------------------------------------------------ the CLI
def test_cli_refuses_a_stdin_that_is_not_a_terminal(monkeypatch, capsys):
    with open(os.devnull) as devnull:
        monkeypatch.setattr(sys, "stdin", devnull)
        assert main(["--bridge", "ws://127.0.0.1:9"]) == 2
    assert "not a terminal" in capsys.readouterr().err
    assert main(["--rate", "0"]) == 2


def test_cli_reports_a_bad_config_and_an_unreachable_bridge(monkeypatch, tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[vessel]\nmax_surge_force_n = -1\n")
    assert main(["--config", str(bad)]) == 2
    read_fd, write_fd = os.pipe()
    with os.fdopen(read_fd) as keys_in:
        monkeypatch.setattr(sys, "stdin", keys_in)
        unreachable = ["--stdin-keys", "--bridge", "ws://127.0.0.1:9", "--connect-timeout", "0.3"]
        assert main(unreachable) == 1
    os.close(write_fd)
    err = capsys.readouterr().err
    assert "cannot use config" in err and "cannot reach the bridge" in err


def wrench_values(msg: dict) -> tuple[float, float]:
    return msg["force"]["x"], msg["torque"]["z"]


async def next_wrench(sub, timeout_s: float = 10.0) -> tuple[float, float]:
    async with asyncio.timeout(timeout_s):
        return wrench_values((await anext(sub)).msg)


async def wrench_changes(
    sub, start: tuple[float, float], last: tuple[float, float]
) -> list[tuple[float, float]]:
    """The successive distinct wrench values after `start` (repeats sent at the steady rate
    are skipped), up to and including `last`."""
    changes = [start]
    while len(changes) == 1 or changes[-1] != last:
        value = await next_wrench(sub)
        if value != changes[-1]:
            changes.append(value)
    return changes[1:]


@pytest.mark.slow
async def test_cli_publishes_on_keys_steadily_and_zero_on_quit(monkeypatch, registry):
    read_fd, write_fd = os.pipe()
    async with (
        run_bridge(BridgeConfig(host="127.0.0.1", port=0)) as bridge,
        RosbridgeClient(bridge.url, registry=registry) as listener,
    ):
        sub = await listener.subscribe(*TOPICS["cmd_wrench"].pair, maxsize=1000)
        with os.fdopen(read_fd) as keys_in:
            monkeypatch.setattr(sys, "stdin", keys_in)
            cli = asyncio.create_task(
                asyncio.to_thread(main, ["--bridge", bridge.url, "--stdin-keys", "--rate", "10"])
            )
            try:
                assert await next_wrench(sub) == (0.0, 0.0)
                os.write(write_fd, b"ww\x1b[C")
                assert await wrench_changes(sub, (0.0, 0.0), (800.0, -600.0)) == [
                    (400.0, 0.0),
                    (800.0, 0.0),
                    (800.0, -600.0),
                ]
                # no keys for a while: the command keeps coming at the steady rate
                repeats = [await next_wrench(sub) for _ in range(5)]
                assert repeats == [(800.0, -600.0)] * 5
                os.write(write_fd, b"q")
                assert await asyncio.wait_for(cli, 10.0) == 0
                # quitting stops the vessel: a zero wrench is the last word
                assert await wrench_changes(sub, (800.0, -600.0), (0.0, 0.0)) == [(0.0, 0.0)]
            finally:
                os.close(write_fd)
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(cli, 10.0)


# ------------------------------------------------------------------ against the simulator


def yaw_of(odom: dict) -> float:
    q = odom["pose"]["pose"]["orientation"]
    return 2.0 * math.atan2(q["z"], q["w"])


async def latest_odom(sub, timeout_s: float = 10.0) -> dict:
    async with asyncio.timeout(timeout_s):
        latest = (await anext(sub)).msg
    while (item := sub.get_nowait()) is not None:
        latest = item.msg
    return latest


@pytest.mark.slow
async def test_teleop_in_a_terminal_steers_the_simulated_vessel(tmp_path, registry):
    config = light_config(tmp_path, resolution_deg=4.0, camera_width_px=80)
    controller, terminal = os.openpty()
    settings_before = termios.tcgetattr(terminal)
    try:
        with running_bridge() as (_, url), running(simulator_argv(url, config)) as sim:
            teleop = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "simulator.teleop_cli",
                    "--bridge",
                    url,
                    "--config",
                    str(config),
                    "--connect-timeout",
                    "60",
                ],
                cwd=REPO_ROOT,
                stdin=terminal,
                stdout=terminal,
                stderr=terminal,
                env={**os.environ, "PYTHONPATH": str(REPO_ROOT)},
            )
            try:
                async with RosbridgeClient(url, registry=registry, connect_timeout=60) as c:
                    odom = await c.subscribe(*TOPICS["odom"].pair, maxsize=1000)
                    await asyncio.to_thread(sim.wait_for_line, re.compile("simulator connected"))
                    await asyncio.to_thread(wait_for_output, controller, "q: quit", 60.0)
                    before = await latest_odom(odom)
                    os.write(controller, b"\x1b[A" * 10 + b"a")  # full ahead, a little to port
                    await asyncio.sleep(4.0)
                    after = await latest_odom(odom)
                    shown = await asyncio.to_thread(wait_for_output, controller, "+600 N m", 10)
                    os.write(controller, b"q")
                    code = await asyncio.to_thread(teleop.wait, 15.0)
            finally:
                if teleop.poll() is None:
                    teleop.kill()
                    teleop.wait()
        settings_after = termios.tcgetattr(terminal)
    finally:
        os.close(controller)
        os.close(terminal)
    assert code == 0
    assert settings_after == settings_before  # cbreak mode undone
    assert "\rsurge  +4000 N (+100%)  yaw   +600 N m ( +10%)" in shown  # the status line
    speed_mps = after["twist"]["twist"]["linear"]["x"]
    turned_rad = math.remainder(yaw_of(after) - yaw_of(before), math.tau)
    assert before["twist"]["twist"]["linear"]["x"] == pytest.approx(0.0, abs=0.05)
    assert speed_mps > 0.5, after["twist"]
    assert turned_rad > 0.1, (yaw_of(before), yaw_of(after))  # port = counter-clockwise


def wait_for_output(fd: int, text: str, timeout_s: float) -> str:
    """Read the terminal's output until `text` appears (AssertionError after `timeout_s`)."""
    seen, deadline = b"", time.monotonic() + timeout_s
    os.set_blocking(fd, False)
    while text.encode() not in seen:
        if time.monotonic() > deadline:
            raise AssertionError(f"teleop never showed {text!r}; it wrote {seen!r}")
        try:
            seen += os.read(fd, 4096)
        except BlockingIOError:
            time.sleep(0.05)
    return seen.decode(errors="replace")
