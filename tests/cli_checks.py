"""What every command line's tests check the same way: a bad option exits 2 naming it."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import pytest


def assert_refused(
    main: Callable[[list[str]], int],
    argv: Sequence[str],
    option: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`main(argv)` exits 2, through argparse's SystemExit or its return value, and its stderr
    names `option`."""
    try:
        code = main(list(argv))
    except SystemExit as exited:
        code = exited.code  # type: ignore[assignment]
    assert code == 2, f"{argv}: exit {code}"
    assert option in capsys.readouterr().err
