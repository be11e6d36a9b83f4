"""`--zenoh` and its options on `riverbridge bridge`: parsed into the config, refused with exit 2
naming the field when wrong."""

from __future__ import annotations

import pytest

from bridge.cli import build_parser, config_from_args, main


def test_options_reach_the_config(tmp_path):
    file = tmp_path / "zenoh.json5"
    file.write_text('{ mode: "peer" }')
    args = build_parser().parse_args(
        [
            "--zenoh",
            "--domain",
            "7",
            "--zenoh-listen",
            "tcp/127.0.0.1:0",
            "--zenoh-connect",
            "tcp/127.0.0.1:7447,tcp/[::1]:7447",
            "--zenoh-config",
            str(file),
            "--zenoh-distro",
            "humble",
        ]
    )
    config = config_from_args(args)
    assert config.zenoh and config.dds_domain == 7 and config.zenoh_distro == "humble"
    assert config.zenoh_listen == ("tcp/127.0.0.1:0",)
    assert config.zenoh_connect == ("tcp/127.0.0.1:7447", "tcp/[::1]:7447")
    assert config.zenoh_config == file


@pytest.mark.parametrize(
    ("argv", "keys"),
    [
        (["--zenoh"], "jazzy"),
        (["--zenoh", "--ros-distro", "humble"], "humble"),
        (["--zenoh", "--ros-distro", "humble", "--zenoh-distro", "kilted"], "kilted"),
    ],
)
def test_the_zenoh_keys_follow_the_ros_distro_unless_told_otherwise(argv, keys):
    assert config_from_args(build_parser().parse_args(argv)).zenoh_keys_distro() == keys


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--zenoh", "--zenoh-listen", "not an endpoint"], "zenoh_listen"),
        (["--zenoh", "--zenoh-config", "/no/such/file.json5"], "--zenoh-config"),
        (["--zenoh", "--zenoh-distro", "iron"], "--zenoh-distro"),
    ],
)
def test_bad_options_exit_2_naming_them(argv, named, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    assert named in capsys.readouterr().err


def test_a_config_file_zenoh_refuses_exits_2(tmp_path, capsys):
    file = tmp_path / "bad.json5"
    file.write_text("{ mode: ")
    with pytest.raises(SystemExit) as exit_:
        main(["--zenoh", "--zenoh-config", str(file)])
    assert exit_.value.code == 2
    assert "Zenoh configuration refused" in capsys.readouterr().err
