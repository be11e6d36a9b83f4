"""Options derived from a configuration model (schemas.options): the bridge's command line,
`riverbridge up`'s pass-through of it, and the words of their errors."""

from __future__ import annotations

import argparse

import pytest
from pydantic import ValidationError

from schemas.bridge_config import GROUPS, BridgeConfig
from schemas.options import add_options, config_values, invalid_options, passed_through, spelled


def bridge_parser(env: dict[str, str] | None = None) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bridge", exit_on_error=False)
    add_options(parser, BridgeConfig, GROUPS, env=env or {})
    return parser


def test_every_option_is_listed_once_under_its_group_in_help():
    text = bridge_parser().format_help()
    for spell in spelled(BridgeConfig):
        heading = text.index(f"\n{spell.option.group}:")
        nxt = min((i for i in (text.find("\n\n", heading + 1),) if i > 0), default=len(text))
        assert spell.option.flag in text[heading:nxt], spell.option.flag
        listed = (f"  {spell.option.flag}{end}" for end in (" ", "\n", ", --no-"))  # paired
        assert sum(text.count(spelling) for spelling in listed) == 1


def test_passed_through_options_give_the_bridge_the_same_configuration(tmp_path):
    secret, cert, key = (tmp_path / name for name in ("secret", "cert.pem", "key.pem"))
    for path in (secret, cert, key):
        path.write_text("s3cret\n")
    names = [s.name for s in spelled(BridgeConfig)]
    up = argparse.ArgumentParser()
    add_options(up, BridgeConfig, GROUPS, names=names, passing=" (passed on)")
    given = [
        *("--port", "0", "--max-clients", "3", "--dds", "--dds-untuned", "--no-dds-parameters"),
        *("--dds-peer", "10.0.0.2,10.0.0.3", "--dds-peer", "10.0.0.4"),
        *("--allowed-origins", "https://a.example.org", "http://b:8080"),
        *("--auth-secret-file", str(secret), "--certfile", str(cert), "--keyfile", str(key)),
        *("--topics-glob", "/cam/*", "--call-timeout", "1.5", "--dds-multicast", "spdp"),
    ]
    argv = passed_through(up.parse_args(given), BridgeConfig, names)
    assert passed_through(up.parse_args([]), BridgeConfig, names) == ()
    direct = BridgeConfig(**config_values(bridge_parser().parse_args(given), BridgeConfig))
    through = BridgeConfig(**config_values(bridge_parser().parse_args(argv), BridgeConfig))
    assert through == direct
    assert through.dds_peers == ("10.0.0.2", "10.0.0.3", "10.0.0.4")
    assert through.dds_tuned is False and through.max_clients == 3
    assert through.dds_parameters is False and "--no-dds-parameters" in argv
    assert through.auth_secret is not None
    assert through.auth_secret.get_secret_value() == "s3cret"


def test_the_environment_gives_defaults_the_command_line_replaces():
    env = {"RIVERBRIDGE_DDS_PEERS": "10.0.0.2, 10.0.0.3", "ROS_DOMAIN_ID": "7"}
    args = bridge_parser(env).parse_args([])
    assert config_values(args, BridgeConfig)["dds_peers"] == ("10.0.0.2", "10.0.0.3")
    args = bridge_parser(env).parse_args(["--dds-peer", "10.0.0.9", "--domain", "8"])
    values = config_values(args, BridgeConfig)
    assert values["dds_peers"] == ("10.0.0.9",) and values["dds_domain"] == 8


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--port", "70000"], "argument --port: must be 0..65535, got 70000"),
        (["--port", "x"], "argument --port: not an integer: 'x'"),
        (["--max-message-size", "0"], "must be a positive integer, got 0"),
        (["--call-timeout", "0"], "must be a positive number, got 0"),
        (["--send-buffer", "1000"], "must be at least 65536 bytes, got 1000"),
        (["--interfaces", "/no/such/dir"], "/no/such/dir is not a directory"),
        (["--certfile", "/no/such.pem"], "no such file: /no/such.pem"),
    ],
)
def test_a_bad_value_is_refused_in_words_naming_the_option(argv, words):
    with pytest.raises(argparse.ArgumentError) as refused:
        bridge_parser().parse_args(argv)
    assert words in str(refused.value)


def test_what_the_model_refuses_is_named_by_option_and_field():
    args = bridge_parser().parse_args(["--dds-interface", "lo;reboot"])
    with pytest.raises(ValidationError) as refused:
        BridgeConfig(**config_values(args, BridgeConfig))
    words = invalid_options(refused.value, BridgeConfig)
    assert words.startswith("argument --dds-interface: dds_interface: ")
    assert "'lo;reboot'" in words


def test_a_bad_environment_variable_is_named():
    with pytest.raises(SystemExit) as exited:
        bridge_parser({"ROS_DOMAIN_ID": "many"})
    assert exited.value.code == 2
