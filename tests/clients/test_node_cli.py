"""The simulator's and navigation's command lines refuse bad shared options by name (exit 2)."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from navigation import cli as nav_cli
from simulator import cli as sim_cli

MAINS = {"simulator": sim_cli.main, "navigation": nav_cli.main}


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
    main: Callable[[list[str]], int] = MAINS[node]
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert option in capsys.readouterr().err
