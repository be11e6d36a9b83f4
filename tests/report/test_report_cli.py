"""`riverbridge report`: option errors, and a real 10 s run of the whole stack."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from clients.report.cli import main, profile_sim_config
from clients.report.journeys import STAGES as JOURNEY_STAGES
from clients.report.journeys import TRANSPORT
from tests.cli_checks import assert_refused

SENSORS = {
    "/lidar/points": 2.0,
    "/radar/image": 2.0,
    "/camera/image/compressed": 2.0,
    "/imu/data": 50.0,
}
STAGES = (*JOURNEY_STAGES, TRANSPORT, "result")


@pytest.mark.parametrize(
    "argv, option",
    [
        (["--duration", "0"], "--duration"),
        (["--encoding", "xml"], "--encoding"),
        (["--json", "/no/such/folder/r.json"], "--json"),
        (["--bridge", "localhost:9090"], "--bridge"),
        (["--sim-config", "/no/such.toml"], "--sim-config"),
        (["--profile", "fast"], "--profile"),
        (["--link", "5g"], "--link"),
    ],
)
def test_bad_options_name_the_option_and_exit_2(argv, option, capsys):
    assert_refused(main, argv, option, capsys)


def test_a_profile_the_sim_config_sets_itself_is_refused(tmp_path, capsys):
    config = tmp_path / "sim.toml"
    config.write_text('profile = "default"\n')
    assert main(["--profile", "thesis", "--sim-config", str(config)]) == 2
    assert "--profile" in capsys.readouterr().err


def test_the_thesis_profile_goes_ahead_of_the_users_settings(tmp_path):
    mine = tmp_path / "mine.toml"
    mine.write_text('seed = 3\n[lidar]\nwater_model = "mesh"\n')
    assert profile_sim_config("default", mine, tmp_path) == mine
    assert profile_sim_config("default", None, tmp_path) is None
    written = profile_sim_config("thesis", mine, tmp_path)
    assert written is not None and written.parent == tmp_path
    from simulator.config import load_config

    config = load_config(written)
    assert (config.profile, config.seed, config.lidar.point_fields, config.lidar.water_model) == (
        "thesis",
        3,
        "xyz",
        "mesh",
    )


def test_unreachable_bridge_fails_with_1(capsys, tmp_path):
    code = main(
        [
            "--bridge",
            "ws://127.0.0.1:9",
            "--duration",
            "1",
            "--warmup",
            "1",
            "--log",
            str(tmp_path / "log"),
        ]
    )
    assert code == 1
    assert "riverbridge report" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.timeout(200)
def test_a_report_of_both_profiles_is_complete_and_consistent(tmp_path: Path):
    out = tmp_path / "r.json"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "clients.report.cli",
            "--duration",
            "8",
            "--warmup",
            "3",
            "--profile",
            "default,thesis",
            "--json",
            str(out),
            "--log",
            str(tmp_path / "stack.log"),
        ],
        capture_output=True,
        text=True,
        timeout=190,
        cwd=Path(__file__).resolve().parents[2],
    )
    assert done.returncode == 0, done.stderr[-2000:] + (tmp_path / "stack.log").read_text()[-3000:]
    assert "/lidar/points" in done.stdout and "thesis Ø 86 ms (table A.1 5b)" in done.stdout
    document = json.loads(out.read_text())
    run, thesis = document["runs"]
    assert (run["profile"], run["water_model"], thesis["profile"]) == ("default", "mesh", "thesis")
    assert thesis["water_model"] == "specular" and thesis["point_fields"] == "xyz"
    # the thesis profile sends about the thesis's 285.37 KB per scan (table 4.9)
    assert 0.8 * 285_370 < thesis["topics"]["/lidar/points"]["payload_bytes_mean"] < 1.2 * 285_370
    rows = document["thesis_comparison"]
    assert {r["run"] for r in rows} == {"cbor", "thesis/cbor"}
    assert all(r["source"] and r["statistic"] for r in rows)
    for each in (run, thesis):
        quality = each["detection_quality"]
        assert quality["lidar"] and quality["radar"], (
            f"{each['profile']}: no output paired with its ground truth in the window",
            quality,
        )
        for sensor in ("lidar", "radar"):  # obstacles on the water (docs/quality.md)
            on_water = quality[sensor]["on_water"]
            assert on_water["precision"] >= 0.9 and on_water["recall"] >= 0.8, (sensor, on_water)
            assert on_water["objects"] > 0
        radar = quality["radar"]
        assert radar["open_water_false_alarm_rate"] <= radar["configured_false_alarm_rate"]
        network = each["network"]
        assert set(network["stack_bytes_per_s_by_process"]) == {"bridge", "simulator", "navigation"}
        # every hop at least once: the sensor payload reaches the bridge and goes on
        assert network["stack_over_sensor_payload"] > 1.5
    assert run["encoding"] == "cbor" and len(run["hosts"]) == 1
    for topic, rate_hz in SENSORS.items():
        summary = run["topics"][topic]
        assert 0.6 * rate_hz <= summary["rate_hz"] <= 1.2 * rate_hz, (topic, summary["rate_hz"])
        assert summary["wire_in_bytes"] >= summary["payload_bytes"] > 0
        assert summary["wire_out_bytes"] >= summary["payload_bytes"]
        assert summary["thesis"]["transport"] > 0
        assert topic in run["samples"]
        for stage in STAGES:
            p = summary["stages"][stage]
            assert p["n"] > 0, (topic, stage)
            assert p["p50"] <= p["p90"] <= p["p99"] <= p["max"], (topic, stage, p)
    lidar = run["topics"]["/lidar/points"]
    assert {"process.dbscan", "process.boxes"} <= set(lidar["stages"])
    assert "points" in run["samples"]["/lidar/points"]
    assert {"bridge", "simulator", "navigation"} <= set(run["processes"])
    assert run["network"]["loopback_bytes_per_s"] > run["network"]["payload_bytes_per_s"] * 0.5
    assert "/imu/data" in run["bridge"]["topics"]
