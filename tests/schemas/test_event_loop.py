"""The event loop choice (`schemas.runtime.event_loop`): the standard loop by default, uvloop
on request, and a bad choice refused by name, also by the bridge's CLI."""

from __future__ import annotations

import asyncio

import pytest

from bridge.cli import main as bridge_main
from schemas.runtime import event_loop
from schemas.runtime.event_loop import EVENT_LOOP_ENV, EventLoopChoiceError, chosen_loop


def test_asyncio_is_the_default_and_uvloop_can_be_chosen() -> None:
    assert chosen_loop({}) == "asyncio"
    assert chosen_loop({EVENT_LOOP_ENV: ""}) == "asyncio"
    assert chosen_loop({EVENT_LOOP_ENV: " UVLOOP "}) == "uvloop"  # in the test extra


def test_an_unknown_loop_is_refused_by_name() -> None:
    with pytest.raises(EventLoopChoiceError, match=f"{EVENT_LOOP_ENV}='trio'"):
        chosen_loop({EVENT_LOOP_ENV: "trio"})


@pytest.mark.parametrize("name", ["uvloop", "asyncio"])
def test_run_runs_on_the_chosen_loop(name: str) -> None:
    async def which() -> str:
        await asyncio.sleep(0)
        return event_loop.running_loop_name()

    assert event_loop.run(which(), name) == name


def test_the_bridge_cli_exits_2_naming_a_bad_loop(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv(EVENT_LOOP_ENV, "trio")
    with pytest.raises(SystemExit) as exit_info:
        bridge_main(["--port", "0"])
    assert exit_info.value.code == 2
    assert EVENT_LOOP_ENV in capsys.readouterr().err
