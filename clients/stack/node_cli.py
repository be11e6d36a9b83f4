"""What the simulator's and the navigation service's command lines share.

Both are rosbridge clients configured by a TOML file: the same connection options, the same
exit codes (0 a clean stop, 2 a bad config, 1 an unreachable bridge) and the same shutdown on
SIGINT/SIGTERM or after `--duration` seconds.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
from collections.abc import Awaitable, Callable
from typing import TypeVar

from clients.errors import ConnectionFailed

Config = TypeVar("Config")


def add_node_arguments(parser: argparse.ArgumentParser, config_tables: str) -> None:
    """--bridge, --config, --encoding, --duration, --connect-timeout, --log-level."""
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument("--config", help=f"TOML file with {config_tables} tables")
    parser.add_argument("--encoding", choices=("cbor", "json"), default="cbor")
    parser.add_argument(
        "--duration",
        type=float,
        default=0.0,
        help="stop after this many seconds (0: run until SIGINT/SIGTERM)",
    )
    parser.add_argument(
        "--connect-timeout",
        type=float,
        default=10.0,
        help="seconds to keep retrying the first connection",
    )
    parser.add_argument("--log-level", default="INFO")


async def run_until_stopped(
    serve: Callable[[asyncio.Event], Awaitable[None]], duration_s: float = 0.0
) -> None:
    """Run `serve(stop)` until SIGINT, SIGTERM or `duration_s` (> 0) sets `stop`."""
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    handled = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop.set)
        except (RuntimeError, ValueError):  # not the main thread (e.g. called from a test)
            break
        handled.append(sig)
    if duration_s > 0:
        loop.call_later(duration_s, stop.set)
    try:
        await serve(stop)
    finally:
        for sig in handled:
            loop.remove_signal_handler(sig)


def run_node(
    args: argparse.Namespace,
    log: logging.Logger,
    load_config: Callable[[str], Config],
    default: Callable[[], Config],
    serve: Callable[[Config, asyncio.Event], Awaitable[None]],
) -> int:
    """Configure logging, load `args.config` (else `default()`), run `serve(config, stop)`.

    Returns the exit code: 0 on a clean stop, 2 when the config cannot be used (the message
    names the file and the field), 1 when the bridge cannot be reached.
    """
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    try:
        config = load_config(args.config) if args.config else default()
    except (OSError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        log.error("cannot use config %s: %s", args.config, exc)
        return 2
    try:
        asyncio.run(run_until_stopped(lambda stop: serve(config, stop), args.duration))
    except ConnectionFailed as exc:
        log.error("cannot reach the bridge at %s: %s", args.bridge, exc)
        return 1
    return 0
