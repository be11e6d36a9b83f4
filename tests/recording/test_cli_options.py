"""`riverbridge record` and `play` refuse bad options by name (exit 2) and an unreachable
bridge with exit 1."""

from __future__ import annotations

from pathlib import Path

import pytest

from clients.recording import play_cli, record_cli
from clients.recording.mcap_file import McapRecording
from tests.cli_checks import assert_refused


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--output", "/no/such/folder/run.mcap"], "--output"),
        (["--output", "run.mcap", "--bridge", "http://x:1"], "--bridge"),
        (["--output", "run.mcap", "--topics", "imu"], "--topics"),
        (["--output", "run.mcap", "--duration", "-1"], "--duration"),
        (["--output", "run.mcap", "--compression", "gzip"], "--compression"),
    ],
)
def test_record_names_the_bad_option(
    argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert_refused(record_cli.main, argv, option, capsys)


def test_record_without_a_bridge_exits_1(tmp_path: Path) -> None:
    code = record_cli.main(
        [
            "--bridge",
            "ws://127.0.0.1:9",
            "--output",
            str(tmp_path / "run.mcap"),
            "--connect-timeout",
            "0.5",
        ]
    )
    assert code == 1


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--stamps", "later"], "--stamps"),
        (["--rate", "-2"], "--rate"),
        (["--topics", "lidar"], "--topics"),
    ],
)
def test_play_names_the_bad_option(
    argv: list[str], option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    recording = tmp_path / "empty.mcap"
    McapRecording(recording).close()
    assert_refused(play_cli.main, [str(recording), *argv], option, capsys)


def test_play_without_a_bridge_exits_1(tmp_path: Path) -> None:
    recording = tmp_path / "empty.mcap"
    McapRecording(recording).close()
    assert (
        play_cli.main([str(recording), "--bridge", "ws://127.0.0.1:9", "--connect-timeout", "0.5"])
        == 1
    )
