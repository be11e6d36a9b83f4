"""`riverbridge up`'s command line: bad options fail fast, naming the option."""

from __future__ import annotations

import sys

import pytest

from clients.stack import up_cli
from clients.stack.launcher import LaunchConfig
from tests.child_process import run_command
from tests.cli_checks import assert_refused


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--port", "70000"], "--port"),
        (["--port", "nine"], "--port"),
        (["--sim-config", "/nonexistent/sim.toml"], "--sim-config"),
        (["--nav-config", "/nonexistent/nav.toml"], "--nav-config"),
        (["--encoding", "xml"], "--encoding"),
        (["--startup-timeout", "0"], "--startup-timeout"),
        (["--startup-timeout", "soon"], "--startup-timeout"),
        (["--stop-timeout", "-1"], "--stop-timeout"),
        (["--frobnicate"], "--frobnicate"),
        (["--restart", "sometimes"], "--restart"),
        (["--auth-secret-file", "/nonexistent/secret"], "--auth-secret-file"),
        (["--certfile", "/nonexistent/cert.pem"], "--certfile"),
        (["--certfile", __file__], "--certfile/--keyfile"),
        (["--max-clients", "0"], "--max-clients"),
    ],
)
def test_bad_option_exits_2_naming_it(
    argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert_refused(up_cli.main, argv, option, capsys)


def test_missing_config_file_through_the_real_command_line() -> None:
    """Started as users start it; nothing is launched, the message names option and file."""
    result = run_command(
        [sys.executable, "-m", "clients.stack.up_cli", "--nav-config", "missing-nav.toml"]
    )
    assert result.returncode == 2
    assert "--nav-config" in result.stderr and "missing-nav.toml" in result.stderr
    assert "started" not in result.stdout


def test_options_become_the_launch_config(tmp_path) -> None:
    sim_toml, nav_toml = tmp_path / "sim.toml", tmp_path / "nav.toml"
    sim_toml.write_text("")
    nav_toml.write_text("")
    args = up_cli.build_parser().parse_args(
        [
            "--host",
            "0.0.0.0",
            "--port",
            "0",
            "--encoding",
            "json",
            "--sim-config",
            str(sim_toml),
            "--nav-config",
            str(nav_toml),
            "--startup-timeout",
            "30",
            "--stop-timeout",
            "2.5",
        ]
    )
    assert up_cli.config_from_args(args) == LaunchConfig(
        host="0.0.0.0",
        port=0,
        encoding="json",
        sim_config=sim_toml.resolve(),
        nav_config=nav_toml.resolve(),
        startup_timeout_s=30.0,
        stop_timeout_s=2.5,
    )


def test_defaults_are_rosbridges_port_on_loopback_with_cbor() -> None:
    config = up_cli.config_from_args(up_cli.build_parser().parse_args([]))
    assert (config.host, config.port, config.encoding) == ("127.0.0.1", 9090, "cbor")
    assert config.sim_config is None and config.nav_config is None


def test_access_options_reach_the_bridge_and_the_clients(tmp_path) -> None:
    from clients.connection import AUTH_SECRET_ENV
    from clients.stack.launcher import access_environment, stack_components

    secret, cert, key = (tmp_path / name for name in ("secret", "cert.pem", "key.pem"))
    for path in (secret, cert, key):
        path.write_text("x\n")
    args = up_cli.build_parser().parse_args(
        [
            "--auth-secret-file",
            str(secret),
            "--certfile",
            str(cert),
            "--keyfile",
            str(key),
            "--allowed-origins",
            "https://*.example.org",
            "--max-clients",
            "20",
            "--restart",
            "always",
        ]
    )
    config = up_cli.config_from_args(args)
    assert config.restart == "always" and config.scheme == "wss"
    bridge = stack_components(config)[0]
    assert bridge.args[4:] == (
        "--auth-secret-file",
        str(secret.resolve()),
        "--certfile",
        str(cert.resolve()),
        "--keyfile",
        str(key.resolve()),
        "--allowed-origins",
        "https://*.example.org",
        "--max-clients",
        "20",
    )
    assert access_environment(config) == {
        AUTH_SECRET_ENV: str(secret.resolve()),
        "SSL_CERT_FILE": str(cert.resolve()),
    }


def test_restart_defaults_to_on_failure() -> None:
    assert up_cli.config_from_args(up_cli.build_parser().parse_args([])).restart == "on-failure"
