"""Is the bridge up, and does each given topic have a publisher? A check through the bridge.

``python -m clients.stack.healthcheck --bridge ws://bridge:9090 [--topic /lidar/points ...]``
exits 0 when the bridge answers ``GET /version`` and every ``--topic`` has at least one
publisher in ``/rosapi/publishers``, 1 otherwise (with the reason on stderr). Docker compose
runs it as the services' health checks; ``riverbridge up`` uses the same functions to decide
that a component is ready. A topic *listed* in ``/rosapi/topics`` is not enough: a subscriber
with a type makes the bridge list the topic too (the navigation service subscribes to the
simulator's topics before the simulator exists), so readiness means a publisher.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import ssl
import sys
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from clients.client import RosbridgeClient
from clients.errors import RosbridgeError

DEFAULT_TIMEOUT_S = 5.0  # whole check; docker's own healthcheck timeout should be larger


class Unhealthy(RuntimeError):
    """The check failed; the message says what is missing."""


def version_url(bridge_url: str) -> str:
    """``ws://h:p[/...]`` -> ``http://h:p/version`` (``wss`` -> ``https``): the bridge serves
    HTTP ``GET /version`` on its websocket port."""
    parts = urllib.parse.urlsplit(bridge_url)
    schemes = {"ws": "http", "wss": "https", "http": "http", "https": "https"}
    if parts.scheme not in schemes or not parts.netloc:
        raise ValueError(f"not a ws:// URL: {bridge_url!r}")
    return urllib.parse.urlunsplit((schemes[parts.scheme], parts.netloc, "/version", "", ""))


def fetch_version(
    bridge_url: str, timeout_s: float = DEFAULT_TIMEOUT_S, cafile: Path | None = None
) -> dict[str, Any]:
    """Blocking ``GET /version``; returns the JSON body. Raises :class:`Unhealthy`.

    ``cafile``: for https, trust this certificate instead of the default store.
    """
    url = version_url(bridge_url)
    context = ssl.create_default_context(cafile=str(cafile)) if cafile is not None else None
    try:
        with urllib.request.urlopen(url, timeout=timeout_s, context=context) as response:
            body = json.loads(response.read())
    except (OSError, ValueError) as exc:  # URLError, timeouts and refused connections are OSError
        raise Unhealthy(f"GET {url} failed: {exc}") from exc
    if not isinstance(body, dict) or "protocol" not in body:
        raise Unhealthy(f"GET {url} answered {body!r}, not a rosbridge version")
    return body


async def missing_publishers(
    client: RosbridgeClient, topics: Sequence[str], timeout_s: float = DEFAULT_TIMEOUT_S
) -> list[str]:
    """The ``topics`` that have no publisher right now, in the given order."""
    replies = await asyncio.gather(
        *(
            client.call_service("/rosapi/publishers", {"topic": topic}, timeout=timeout_s)
            for topic in topics
        )
    )
    return [
        topic for topic, reply in zip(topics, replies, strict=True) if not reply.get("publishers")
    ]


async def check(
    bridge_url: str, topics: Sequence[str], timeout_s: float = DEFAULT_TIMEOUT_S
) -> dict[str, Any]:
    """One full check: ``/version``, then the publishers of ``topics`` (if any).

    Returns the bridge's version body. Raises :class:`Unhealthy` naming what failed.
    """
    version = await asyncio.to_thread(fetch_version, bridge_url, timeout_s)
    if not topics:
        return version
    client = RosbridgeClient(
        bridge_url, encoding="json", name="healthcheck", connect_timeout=timeout_s, reconnect=False
    )
    try:
        async with asyncio.timeout(timeout_s):
            await client.connect()
            missing = await missing_publishers(client, topics, timeout_s)
    except (RosbridgeError, TimeoutError) as exc:
        raise Unhealthy(f"rosapi through {bridge_url} failed: {exc!r}") from exc
    finally:
        await client.close()
    if missing:
        raise Unhealthy("no publisher on " + ", ".join(missing))
    return version


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m clients.stack.healthcheck", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument(
        "--topic",
        action="append",
        default=[],
        metavar="TOPIC",
        help="require a publisher on this topic (repeatable)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        help="seconds for the whole check (default %(default)s)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """0 when healthy, 1 when not (reason on stderr), 2 on bad arguments."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.timeout > 0:
        parser.error(f"argument --timeout: must be positive, got {args.timeout}")
    try:
        version_url(args.bridge)
    except ValueError as exc:
        parser.error(f"argument --bridge: {exc}")
    try:
        asyncio.run(check(args.bridge, args.topic, args.timeout))
    except Unhealthy as exc:
        print(f"unhealthy: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
