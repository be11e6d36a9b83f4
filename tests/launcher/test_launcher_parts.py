"""The launcher's pure parts: command lines, environment, addresses, output."""

from __future__ import annotations

import io
import signal
import sys
from pathlib import Path

import pytest

from clients.node.child import BRIDGE_URL, describe_exit
from clients.node.output import PrefixedOutput
from clients.stack.healthcheck import version_url
from clients.stack.launcher import (
    GUIDANCE_TOPICS,
    NAVIGATION_TOPICS,
    SIMULATOR_TOPICS,
    LaunchConfig,
    child_environment,
    connect_host,
    stack_components,
    ws_url,
)


def test_stack_is_bridge_then_simulator_then_navigation_with_their_options() -> None:
    config = LaunchConfig(
        host="0.0.0.0",
        port=9191,
        encoding="json",
        sim_config=Path("/c/sim.toml"),
        nav_config=Path("/c/nav.toml"),
    )
    bridge, sim, nav = stack_components(config)
    url = "ws://127.0.0.1:9191"
    assert bridge.argv(url) == [
        sys.executable,
        "-m",
        "bridge",
        "--host",
        "0.0.0.0",
        "--port",
        "9191",
    ]
    assert sim.argv(url) == [
        sys.executable,
        "-m",
        "simulator",
        "--bridge",
        url,
        "--encoding",
        "json",
        "--config",
        "/c/sim.toml",
    ]
    assert nav.argv(url) == [
        sys.executable,
        "-m",
        "navigation",
        "--bridge",
        url,
        "--encoding",
        "json",
        "--config",
        "/c/nav.toml",
    ]
    assert (sim.topics, nav.topics, bridge.topics) == (SIMULATOR_TOPICS, NAVIGATION_TOPICS, ())


def test_without_config_files_no_config_option_is_passed() -> None:
    _, sim, nav = stack_components(LaunchConfig())
    assert "--config" not in sim.args and "--config" not in nav.args
    assert BRIDGE_URL in sim.args and BRIDGE_URL in nav.args


def test_autopilot_adds_guidance_last_with_its_config() -> None:
    config = LaunchConfig(autopilot=True, guidance_config=Path("/c/guidance.toml"))
    *_, guide = stack_components(config)
    assert guide.argv("ws://h:1") == [
        sys.executable,
        "-m",
        "guidance",
        "--bridge",
        "ws://h:1",
        "--encoding",
        "cbor",
        "--config",
        "/c/guidance.toml",
    ]
    assert (
        guide.topics
        == GUIDANCE_TOPICS
        == ("/guidance/cmd_wrench", "/guidance/target", "/guidance/mode")
    )
    assert len(stack_components(LaunchConfig())) == 3


def test_children_get_unbuffered_output_and_malloc_tuning_over_the_base_env() -> None:
    env = child_environment({"PATH": "/bin", "PYTHONUNBUFFERED": "", "MALLOC_TOP_PAD_": "1"})
    assert env["PATH"] == "/bin"
    assert env["PYTHONUNBUFFERED"] == "1"
    assert env["MALLOC_MMAP_THRESHOLD_"] == str(256 * 2**20)
    assert env["MALLOC_TRIM_THRESHOLD_"] == str(2**30)
    assert env["MALLOC_TOP_PAD_"] == str(64 * 2**20)


@pytest.mark.parametrize(
    ("host", "expected"),
    [
        ("0.0.0.0", "127.0.0.1"),
        ("::", "::1"),
        ("127.0.0.1", "127.0.0.1"),
        ("10.1.2.3", "10.1.2.3"),
    ],
)
def test_clients_connect_to_loopback_when_the_bridge_binds_a_wildcard(
    host: str, expected: str
) -> None:
    assert connect_host(host) == expected


def test_ipv6_urls_are_bracketed() -> None:
    assert ws_url("::1", 9090) == "ws://[::1]:9090"
    assert ws_url("127.0.0.1", 9090) == "ws://127.0.0.1:9090"


def test_exit_descriptions_name_the_component_and_code_or_signal() -> None:
    assert describe_exit("simulator", 3) == "simulator exited with code 3"
    assert describe_exit("simulator", -int(signal.SIGKILL)) == (
        "simulator was killed by SIGKILL (exit code -9)"
    )


def test_version_url_follows_the_websocket_address() -> None:
    assert version_url("ws://bridge:9090") == "http://bridge:9090/version"
    assert version_url("wss://example.org:443/ros") == "https://example.org:443/version"
    with pytest.raises(ValueError, match="not a ws:// URL"):
        version_url("bridge:9090")


def test_output_prefixes_each_line_and_colours_only_when_asked() -> None:
    plain, coloured = io.StringIO(), io.StringIO()
    PrefixedOutput(plain).write("sim", "hello")  # StringIO is not a TTY
    PrefixedOutput(coloured, colour=True).write("nav", "world")
    assert plain.getvalue() == "[sim]    hello\n"
    assert "\x1b[" not in plain.getvalue()
    assert coloured.getvalue().startswith("\x1b[35m[nav]") and "world" in coloured.getvalue()


def test_readiness_topics_are_what_the_components_publish() -> None:
    """The launcher and the components read one catalogue (schemas.catalogue): `up` waits for
    every sensor topic of the simulator (and its /sim/status) and every output of navigation."""
    from navigation.processors import OUTPUT_TYPES
    from schemas.catalogue import TOPICS
    from simulator.sensors import SENSORS

    sensors = {factory.topic.name for factory in SENSORS}
    assert set(SIMULATOR_TOPICS) == sensors | {TOPICS["sim_status"].name}
    assert set(NAVIGATION_TOPICS) == set(OUTPUT_TYPES)
