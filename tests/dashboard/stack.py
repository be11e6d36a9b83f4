"""A whole riverbridge stack (``python -m clients.stack.up_cli --port 0``) as a child process, and
the checks that the browser tooling is in place.

Shared by the dashboard tests and ``benchmarks/dashboard.py``: both drive the same running
stack through the page its bridge serves.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from tests.child_process import REPO_ROOT, repo_env

WEB_DIR = REPO_ROOT / "web"
SCRIPTS_DIR = Path(__file__).resolve().parent
CHROMIUM = Path(os.environ.get("RIVERBRIDGE_CHROMIUM", "/usr/bin/chromium"))
SETUP_HINT = (
    "run: bash scripts/setup.sh   (or: apt-get install -y --no-install-recommends "
    "chromium && npm ci --prefix web && npm run build --prefix web)"
)
# Importing numpy, rosbags, Embree and building the scene on a loaded 2-core machine.
STARTUP_TIMEOUT_S = 180.0
STOP_TIMEOUT_S = 30.0
_READY = re.compile(r"all three ready; connect to ws://(?P<host>[\d.]+):(?P<port>\d+)")


def missing_tools() -> list[str]:
    """What the browser tests need and this machine lacks, each with the command that fixes it."""
    missing = []
    if shutil.which("node") is None:
        missing.append("node (apt-get install -y nodejs npm)")
    if not CHROMIUM.is_file():
        missing.append(f"{CHROMIUM} (apt-get install -y --no-install-recommends chromium)")
    if not (WEB_DIR / "node_modules" / "playwright-core" / "package.json").is_file():
        missing.append("web/node_modules/playwright-core (npm ci --prefix web)")
    if not (WEB_DIR / "dist" / "index.html").is_file():
        missing.append("web/dist/index.html (npm run build --prefix web)")
    return missing


@dataclass(frozen=True)
class Stack:
    host: str
    port: int
    log_path: Path

    @property
    def ws_url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    @property
    def page_url(self) -> str:
        return f"http://{self.host}:{self.port}/"

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")


@contextlib.contextmanager
def running_stack(log_path: Path) -> Iterator[Stack]:
    """Start bridge, simulator and navigation; stop them (SIGINT, then the group) on exit."""
    with log_path.open("w") as log:
        process = subprocess.Popen(
            [sys.executable, "-m", "clients.stack.up_cli", "--port", "0"],
            cwd=REPO_ROOT,
            env=repo_env(),
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        yield _wait_ready(process, log_path)
    finally:
        _stop(process)


def _wait_ready(process: subprocess.Popen[bytes], log_path: Path) -> Stack:
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while time.monotonic() < deadline:
        match = _READY.search(log_path.read_text(errors="replace"))
        if match:
            return Stack(match["host"], int(match["port"]), log_path)
        if process.poll() is not None:
            break
        time.sleep(0.2)
    raise RuntimeError(f"riverbridge up did not become ready:\n{log_path.read_text()}")


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(STOP_TIMEOUT_S)
