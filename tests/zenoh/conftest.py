"""Fixtures for the Zenoh tests: a domain of their own and loopback endpoints on free ports.

Every session in these tests listens or connects on 127.0.0.1 only, with multicast scouting
off (the bridge's default; the independent participant sets it itself).
"""

from __future__ import annotations

import os
import random
import socket
import time
from pathlib import Path
from typing import Any

import pytest

from tests.graph_peers import run_json_peer

PEER = Path(__file__).resolve().parent / "zenoh_peer.py"
_DOMAINS = list(range(100, 231))
random.Random(os.getpid() ^ time.time_ns()).shuffle(_DOMAINS)


@pytest.fixture
def zenoh_domain() -> int:
    return _DOMAINS.pop()


@pytest.fixture
def zenoh_endpoint() -> str:
    """A loopback TCP endpoint on a port free right now, for the bridge to listen on."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    return f"tcp/127.0.0.1:{port}"


async def run_peer(
    endpoint: str, domain: int, *args: str, timeout_s: float = 90.0, distro: str = "jazzy"
) -> Any:
    """Run zenoh_peer.py in its own process (as a node of `distro`); its last JSON line."""
    env = {"PATH": "/usr/bin", "RUST_LOG": "error", "ROS_DISTRO": distro}
    return await run_json_peer(PEER, endpoint, str(domain), *args, env=env, timeout_s=timeout_s)
