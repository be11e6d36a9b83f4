"""The DDS options of `python -m bridge` and `riverbridge up`: defaults, environment, bad
values named on exit, and a domain that cannot be joined."""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET

import pytest

from bridge import cli
from clients.stack import up_cli
from clients.stack.launcher import stack_components
from tests.child_process import run_command


def bridge_config(argv: list[str]):
    return cli.config_from_args(cli.build_parser().parse_args(argv))


def test_dds_is_off_by_default_and_on_loopback_when_on(monkeypatch):
    for name in (
        "RIVERBRIDGE_DDS",
        "ROS_DOMAIN_ID",
        "RIVERBRIDGE_DDS_INTERFACE",
        "RIVERBRIDGE_DDS_PEERS",
    ):
        monkeypatch.delenv(name, raising=False)
    assert bridge_config([]).dds is False
    config = bridge_config(
        [
            "--dds",
            "--domain",
            "42",
            "--dds-peer",
            "10.0.0.2,10.0.0.3",
            "--dds-peer",
            "10.0.0.4",
            "--dds-node",
            "/vessel/bridge",
        ]
    )
    assert (config.dds, config.dds_domain, config.dds_interface) == (True, 42, "lo")
    assert config.dds_peers == ("10.0.0.2", "10.0.0.3", "10.0.0.4")
    assert config.dds_multicast == "false" and config.dds_node == "/vessel/bridge"


def test_environment_gives_defaults_and_options_win(monkeypatch):
    monkeypatch.setenv("RIVERBRIDGE_DDS", "1")
    monkeypatch.setenv("ROS_DOMAIN_ID", "7")
    monkeypatch.setenv("RIVERBRIDGE_DDS_INTERFACE", "eth0")
    monkeypatch.setenv("RIVERBRIDGE_DDS_PEERS", "10.0.0.2, 10.0.0.3")
    config = bridge_config([])
    assert (config.dds, config.dds_domain, config.dds_interface) == (True, 7, "eth0")
    assert config.dds_peers == ("10.0.0.2", "10.0.0.3")
    config = bridge_config(["--domain", "8", "--dds-peer", "10.0.0.9"])
    assert config.dds_domain == 8 and config.dds_peers == ("10.0.0.9",)
    assert config.distro == "jazzy"
    assert bridge_config(["--ros-distro", "humble"]).distro == "humble"


def test_the_bridges_parameter_services_are_on_unless_turned_off(monkeypatch):
    monkeypatch.delenv("RIVERBRIDGE_DDS_PARAMETERS", raising=False)
    assert bridge_config(["--dds"]).dds_parameters is True
    assert bridge_config(["--dds", "--dds-parameters"]).dds_parameters is True  # as before
    assert bridge_config(["--dds", "--no-dds-parameters"]).dds_parameters is False
    monkeypatch.setenv("RIVERBRIDGE_DDS_PARAMETERS", "0")
    assert bridge_config(["--dds"]).dds_parameters is False
    assert bridge_config(["--dds", "--dds-parameters"]).dds_parameters is True


@pytest.mark.parametrize(
    ("argv", "env", "named"),
    [
        (["--dds", "--domain", "233"], {}, "--domain"),
        (["--dds", "--domain", "x"], {}, "--domain"),
        (["--dds", "--dds-interface", "lo;reboot"], {}, "dds_interface"),
        (["--dds", "--dds-peer", "10.0.0.2 10.0.0.3"], {}, "dds_peers"),
        (["--dds", "--dds-multicast", "maybe"], {}, "--dds-multicast"),
        (["--dds", "--dds-node", "not a name"], {}, "dds_node"),
        (["--dds", "--ros-distro", "rolling"], {}, "--ros-distro"),
        (["--dds"], {"ROS_DOMAIN_ID": "many"}, "ROS_DOMAIN_ID"),
        (["--dds"], {"RIVERBRIDGE_DDS": "perhaps"}, "RIVERBRIDGE_DDS"),
    ],
)
def test_bad_dds_options_exit_2_naming_them(argv, env, named, monkeypatch, capsys):
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    with pytest.raises(SystemExit) as exited:
        cli.main(argv)
    assert exited.value.code == 2
    assert named in capsys.readouterr().err


def test_print_dds_config_gives_the_xml_for_ros2_nodes(capsys):
    assert (
        cli.main(["--print-dds-config", "--dds-interface", "veth0", "--dds-peer", "10.0.0.2"]) == 0
    )
    document = ET.fromstring(capsys.readouterr().out)
    assert document.find("Domain/General/Interfaces/NetworkInterface").get("name") == "veth0"
    assert [p.get("address") for p in document.iter("Peer")] == ["10.0.0.2"]


@pytest.mark.slow
def test_a_domain_that_cannot_be_joined_exits_1_with_the_reason(dds_domain):
    result = run_command(
        [
            sys.executable,
            "-m",
            "bridge",
            "--port",
            "0",
            "--dds",
            "--domain",
            str(dds_domain),
            "--dds-interface",
            "nosuch0",
        ]
    )
    assert result.returncode == 1
    assert "cannot join DDS domain" in result.stderr and "nosuch0" in result.stderr
    assert "Traceback" not in result.stderr


def test_up_passes_dds_options_to_the_bridge(capsys):
    args = up_cli.build_parser().parse_args(
        ["--dds", "--domain", "7", "--dds-interface", "eth0", "--dds-peer", "10.0.0.2"]
    )
    bridge, _, _ = stack_components(up_cli.config_from_args(args))
    assert bridge.args[-7:] == (
        "--dds",
        "--domain",
        "7",
        "--dds-interface",
        "eth0",
        "--dds-peer",
        "10.0.0.2",
    )
    assert stack_components(up_cli.config_from_args(up_cli.build_parser().parse_args([])))[
        0
    ].args == ("--host", "127.0.0.1", "--port", "9090")
    off = up_cli.build_parser().parse_args(["--dds", "--no-dds-parameters"])
    assert stack_components(up_cli.config_from_args(off))[0].args[-2:] == (
        "--dds",
        "--no-dds-parameters",
    )
    with pytest.raises(SystemExit):
        up_cli.main(["--domain", "999"])
    assert "--domain" in capsys.readouterr().err
