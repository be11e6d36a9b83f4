"""`python -m guidance`: a bad config names its field and exits 2; an absent bridge exits 1."""

from __future__ import annotations

from pathlib import Path

import pytest

from guidance.cli import main


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("[avoidance]\nclearence_m = 5.0\n", "clearence_m"),
        ("[control]\nrate_hz = 50.0\n", "rate_hz"),
        ("[inputs]\nslow_age_s = 4.0\nstop_age_s = 3.0\n", "slow_age_s < stop_age_s"),
        ("[route]\nwaypoints_utm = [[384000.0, 5720000.0]]\n", "waypoints_utm"),
        ("[route]\nwaypoints_utm = [[1.0, 2.0], [1.0, 2.0]]\n", "repeats point 0"),
    ],
)
def test_a_bad_config_names_the_field_and_exits_2(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, text: str, field: str
) -> None:
    config = tmp_path / "guidance.toml"
    config.write_text(text, encoding="utf-8")
    assert main(["--config", str(config), "--bridge", "ws://127.0.0.1:9"]) == 2
    assert field in caplog.text


def test_an_unreachable_bridge_exits_1(caplog: pytest.LogCaptureFixture) -> None:
    assert main(["--bridge", "ws://127.0.0.1:9", "--connect-timeout", "0.5"]) == 1
    assert "cannot reach the bridge" in caplog.text
