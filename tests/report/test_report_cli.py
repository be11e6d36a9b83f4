"""`riverbridge report`: option errors, and a real 10 s run of the whole stack."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from clients.report_cli import main

SENSORS = {"/lidar/points": 2.0, "/radar/image": 2.0, "/camera/image/compressed": 2.0,
           "/imu/data": 50.0}
STAGES = ("generate", "publish_wait", "encode", "send", "pub_to_bridge", "bridge_in", "fanout",
          "bridge_to_sub", "decode", "wait", "process", "transport", "result")


@pytest.mark.parametrize("argv, option", [
    (["--duration", "0"], "--duration"),
    (["--encoding", "xml"], "--encoding"),
    (["--json", "/no/such/folder/r.json"], "--json"),
    (["--bridge", "localhost:9090"], "--bridge"),
    (["--sim-config", "/no/such.toml"], "--sim-config"),
])
def test_bad_options_name_the_option_and_exit_2(argv, option, capsys):
    assert main(argv) == 2
    assert option in capsys.readouterr().err


def test_unreachable_bridge_fails_with_1(capsys, tmp_path):
    code = main(["--bridge", "ws://127.0.0.1:9", "--duration", "1", "--warmup", "1",
                 "--log", str(tmp_path / "log")])
    assert code == 1
    assert "riverbridge report" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.timeout(150)
def test_a_ten_second_report_is_complete_and_consistent(tmp_path: Path):
    out = tmp_path / "r.json"
    done = subprocess.run(
        [sys.executable, "-m", "clients.report_cli", "--duration", "10", "--warmup", "3",
         "--json", str(out), "--log", str(tmp_path / "stack.log")],
        capture_output=True, text=True, timeout=140, cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 0, done.stderr[-2000:] + (tmp_path / "stack.log").read_text()[-3000:]
    assert "/lidar/points" in done.stdout and "thesis 86 ms" in done.stdout
    (run,) = json.loads(out.read_text())["runs"]
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
