"""A real bridge process for the recording tests, and the recorder/player command lines."""

from __future__ import annotations

import sys
from collections.abc import Iterator

import pytest

from tests.child_process import REPO_ROOT, running

RIVERBRIDGE = [sys.executable, str(REPO_ROOT / "riverbridge.py")]


@pytest.fixture
def bridge_url() -> Iterator[str]:
    """``ws://127.0.0.1:PORT`` of a bridge process started for the test."""
    with running([sys.executable, "-m", "bridge", "--host", "127.0.0.1", "--port", "0"]) as b:
        port = b.wait_for_line(r"listening on ws://127\.0\.0\.1:(?P<port>\d+)")["port"]
        yield f"ws://127.0.0.1:{port}"
