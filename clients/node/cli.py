"""What the command lines of riverbridge's nodes share (simulator, navigation, guidance; `record`
and `play` take the client options and the shutdown).

A node is a rosbridge client configured by a TOML file: the same connection options, the same
exit codes (0 a clean stop, 2 a bad config, 1 an unreachable bridge) and the same shutdown on
SIGINT/SIGTERM or after `--duration` seconds. :func:`node_main` is a node's whole `main`.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
from collections.abc import Awaitable, Callable
from typing import Protocol, TypeVar

from clients.errors import ConnectionFailed
from clients.protocol import Encoding

Config = TypeVar("Config")
Config_contra = TypeVar("Config_contra", contravariant=True)


class NodeServe(Protocol[Config_contra]):
    """A node's `serve`: connect to `url` and run with `config` until `stop` is set."""

    def __call__(
        self,
        url: str,
        config: Config_contra,
        stop: asyncio.Event,
        /,
        *,
        encoding: Encoding,
        connect_timeout_s: float,
    ) -> Awaitable[None]: ...


def node_main(
    argv: list[str] | None,
    *,
    prog: str,
    description: str,
    config_tables: str,
    load_config: Callable[[str], Config],
    default: Callable[[], Config],
    serve: NodeServe[Config],
) -> int:
    """A node's `main`: parse `argv` (bad options exit 2 naming them), then :func:`run_node`
    with `serve` connected the way the options say."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    add_node_arguments(parser, config_tables)
    args = parser.parse_args(argv)
    return run_node(
        args,
        logging.getLogger(prog.split()[-1]),
        load_config,
        default,
        lambda config, stop: serve(
            args.bridge,
            config,
            stop,
            encoding=args.encoding,
            connect_timeout_s=args.connect_timeout,
        ),
    )


def add_node_arguments(parser: argparse.ArgumentParser, config_tables: str) -> None:
    """--bridge, --config, --encoding, --duration, --connect-timeout, --log-level."""
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument("--config", help=f"TOML file with {config_tables} tables")
    parser.add_argument("--encoding", choices=("cbor", "json"), default="cbor")
    parser.add_argument(
        "--duration",
        type=non_negative_seconds,
        default=0.0,
        help="stop after this many seconds (0: run until SIGINT/SIGTERM)",
    )
    add_client_arguments(parser)


LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR", "CRITICAL")


def _number(text: str, unit: str, *, positive: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a {unit}: {text!r}") from None
    if not (value > 0 if positive else value >= 0):  # NaN fails both
        raise argparse.ArgumentTypeError(
            f"must be {'positive' if positive else '0 or more'}, got {text}"
        )
    return value


def non_negative_seconds(text: str) -> float:
    """An argparse type: a number of seconds, 0 or more (NaN refused)."""
    return _number(text, "number of seconds", positive=False)


def positive_seconds(text: str) -> float:
    """An argparse type: a positive number of seconds (NaN refused)."""
    return _number(text, "number of seconds", positive=True)


def positive_number(text: str) -> float:
    """An argparse type: a positive number, e.g. a rate (NaN refused)."""
    return _number(text, "number", positive=True)


def add_client_arguments(parser: argparse.ArgumentParser, log_level: str = "INFO") -> None:
    """--connect-timeout and --log-level (default `log_level`), as every riverbridge client
    command takes them."""
    parser.add_argument(
        "--connect-timeout",
        type=non_negative_seconds,
        default=10.0,
        metavar="S",
        help="seconds to keep trying to reach the bridge (default %(default)s)",
    )
    parser.add_argument(
        "--log-level", type=str.upper, default=log_level, choices=LOG_LEVELS, metavar="LEVEL"
    )


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
