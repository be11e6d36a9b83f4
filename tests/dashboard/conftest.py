"""Fixtures of the dashboard tests: one running stack per module, and the browser tooling."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from .stack import SETUP_HINT, Stack, missing_tools, running_stack


@pytest.fixture(scope="module")
def browser_tools() -> None:
    """Fail (never skip) when Chromium, playwright-core or the web build is missing."""
    missing = missing_tools()
    if missing:
        pytest.fail(
            "the dashboard tests need " + "; ".join(missing) + f"\n{SETUP_HINT}", pytrace=False
        )


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory, browser_tools: None) -> Iterator[Stack]:
    log_path = tmp_path_factory.mktemp("stack") / "up.log"
    with running_stack(log_path) as running:
        yield running
