"""`python -m bridge` as a process, and `main()` argument handling."""

from __future__ import annotations

import asyncio
import json
import re
import signal
import subprocess
import sys

import pytest
import websockets

from bridge.cli import build_parser, config_from_args, main

pytestmark = pytest.mark.timeout(60)


@pytest.mark.slow
async def test_module_starts_logs_its_port_and_exits_cleanly_on_sigint():
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "bridge",
        "--port",
        "0",
        "--log-level",
        "warning",
        stderr=subprocess.PIPE,
    )
    try:
        async with asyncio.timeout(30):
            while True:
                line = (await process.stderr.readline()).decode()
                assert line, "bridge exited before listening"
                match = re.search(r"listening on (ws://[\d.]+:(\d+))", line)
                if match:
                    break
        async with websockets.connect(match.group(1)) as ws:
            await ws.send(
                json.dumps({"op": "call_service", "id": 1, "service": "/rosapi/get_ros_version"})
            )
            response = json.loads(await asyncio.wait_for(ws.recv(), 10))
            assert response["values"] == {"version": 2, "distro": "jazzy"}
        process.send_signal(signal.SIGINT)
        assert await asyncio.wait_for(process.wait(), 20) == 0
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()


@pytest.mark.parametrize(
    "argv, option",
    [
        (["--port", "70000"], "--port"),
        (["--max-message-size", "0"], "--max-message-size"),
        (["--call-timeout", "soon"], "--call-timeout"),
        (["--interfaces", "/no/such/dir"], "--interfaces"),
        (["--send-buffer", "1000"], "--send-buffer"),
    ],
)
def test_bad_arguments_name_the_option(argv, option, capsys):
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code != 0
    assert option in capsys.readouterr().err


def test_arguments_become_the_config():
    args = build_parser().parse_args(
        [
            "--port",
            "0",
            "--topics-glob",
            "/cam/*",
            "--topics-glob",
            "/imu",
            "--send-buffer",
            "70000",
            "--call-timeout",
            "1.5",
        ]
    )
    config = config_from_args(args)
    assert config.port == 0 and config.topics_glob == ("/cam/*", "/imu")
    assert config.send_buffer_bytes == 70_000 and config.call_timeout_s == 1.5
    assert config.max_message_size == 64 * 1024 * 1024
