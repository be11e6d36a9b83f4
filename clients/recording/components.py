"""The recorder and the player as parts of a stack that `riverbridge up` and `report` start.

``up --record FILE`` and ``report --record FILE`` add a recorder process next to the
simulator and navigation (it is stopped with them, SIGINT first, so the file gets its index);
``report --replay FILE`` runs a player in the simulator's place. With ``report --bridge``
there is no supervisor, so :func:`recorder_process` runs the recorder for the measurement.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import sys
from collections.abc import AsyncIterator, Sequence
from pathlib import Path

from clients.node.child import BRIDGE_URL, Component

log = logging.getLogger(__name__)

RECORD_MODULE = "clients.recording.record_cli"
PLAY_MODULE = "clients.recording.play_cli"
STOP_TIMEOUT_S = 30.0  # finishing a file: the last chunk and the index


def recorder_component(output: Path) -> Component:
    """Records every topic of the stack's bridge into ``output``; ready at once."""
    return Component(
        "rec", "recorder", RECORD_MODULE, ("--bridge", BRIDGE_URL, "--output", str(output))
    )


def player_component(recording: Path, topics: Sequence[str]) -> Component:
    """Plays ``topics`` of ``recording`` in a loop (stamps shifted to today's clock); ready
    when each of them has a publisher, like the simulator it stands in for."""
    return Component(
        "play",
        "player",
        PLAY_MODULE,
        (str(recording), "--bridge", BRIDGE_URL, "--loop", "--topics", *topics),
        tuple(topics),
    )


def record_path(path: Path, label: str, runs: int) -> Path:
    """``path`` for a single run; ``name.<label>.mcap`` beside it when several runs record."""
    return path if runs == 1 else path.with_name(f"{path.stem}.{label}{path.suffix}")


@contextlib.asynccontextmanager
async def recorder_process(url: str, output: Path) -> AsyncIterator[asyncio.subprocess.Process]:
    """``riverbridge record`` against ``url`` for the block, then stopped with SIGINT (the
    file gets its summary). Its output goes to this process's stderr."""
    process = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        RECORD_MODULE,
        "--bridge",
        url,
        "--output",
        str(output),
        "--log-level",
        "WARNING",
        stdin=asyncio.subprocess.DEVNULL,
        stdout=sys.stderr,
    )
    try:
        yield process
    finally:
        if process.returncode is None:
            process.send_signal(signal.SIGINT)
        try:
            await asyncio.wait_for(process.wait(), STOP_TIMEOUT_S)
        except TimeoutError:
            log.error(
                "the recorder did not finish %s within %.0f s; killed", output, STOP_TIMEOUT_S
            )
            process.kill()
            await process.wait()
