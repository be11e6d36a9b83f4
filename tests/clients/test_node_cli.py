"""The command lines of the simulator, navigation and guidance (one `node_main`) refuse bad
shared options by name (exit 2)."""

from __future__ import annotations

import pytest

from guidance import cli as guidance_cli
from navigation import cli as nav_cli
from simulator import cli as sim_cli
from tests.cli_checks import assert_refused

MAINS = {"simulator": sim_cli.main, "navigation": nav_cli.main, "guidance": guidance_cli.main}


@pytest.mark.parametrize("node", MAINS)
@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--connect-timeout", "-1"], "--connect-timeout"),
        (["--connect-timeout", "nan"], "--connect-timeout"),
        (["--duration", "soon"], "--duration"),
        (["--log-level", "chatty"], "--log-level"),
    ],
)
def test_a_bad_shared_option_is_named(
    node: str, argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert_refused(MAINS[node], argv, option, capsys)
