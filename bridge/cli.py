"""`python -m bridge`: run the rosbridge v2 websocket server until SIGINT/SIGTERM."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import signal
from pathlib import Path

from pydantic import ValidationError

from bridge.config import MIB, MIN_SEND_BUFFER, BridgeConfig
from bridge.server import run_bridge
from schemas.process_tuning import freeze_startup_heap, tune_process

logger = logging.getLogger("bridge.cli")


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def buffer_bytes(text: str) -> int:
    value = int(text)
    if value < MIN_SEND_BUFFER:
        raise argparse.ArgumentTypeError(f"must be at least {MIN_SEND_BUFFER} bytes, got {text}")
    return value


def port_number(text: str) -> int:
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be 0..65535, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    defaults = BridgeConfig()
    parser = argparse.ArgumentParser(prog="python -m bridge", description=__doc__)
    parser.add_argument("--host", default=defaults.host, help="address to listen on")
    parser.add_argument("--port", type=port_number, default=defaults.port,
                        help="TCP port; 0 picks a free one (default %(default)s)")
    parser.add_argument("--max-message-size", type=positive_int,
                        default=defaults.max_message_size,
                        help="inbound frame limit in bytes; larger frames close with 1009 "
                             f"(default {defaults.max_message_size // MIB} MiB)")
    parser.add_argument("--fragment-timeout", type=positive_float,
                        default=defaults.fragment_timeout_s,
                        help="seconds to wait for missing fragments (default %(default)s)")
    parser.add_argument("--call-timeout", type=positive_float, default=defaults.call_timeout_s,
                        help="default call_service timeout in seconds (default %(default)s)")
    parser.add_argument("--topics-glob", action="append", default=[], metavar="PATTERN",
                        help="allow only topics matching this fnmatch pattern (repeatable)")
    parser.add_argument("--services-glob", action="append", default=[], metavar="PATTERN",
                        help="allow only services matching this fnmatch pattern (repeatable)")
    parser.add_argument("--send-buffer", type=buffer_bytes, default=defaults.send_buffer_bytes,
                        metavar="BYTES",
                        help="bytes a client may leave untaken before each of its topics loses "
                             "its oldest waiting message "
                             f"(default {defaults.send_buffer_bytes // MIB} MiB)")
    parser.add_argument("--offload-threshold", type=positive_int,
                        default=defaults.offload_threshold_bytes, metavar="BYTES",
                        help="payloads at least this large are decoded and encoded in a worker "
                             "thread, off the event loop (default %(default)s)")
    parser.add_argument("--log-level", default="info",
                        choices=["debug", "info", "warning", "error", "critical"])
    parser.add_argument("--interfaces", action="append", default=[], type=Path, metavar="DIR",
                        help="extra folder of <pkg>/{msg,srv,action}/ definitions (repeatable)")
    parser.add_argument("--web-root", type=Path, default=None, metavar="DIR",
                        help="built web dashboard to serve at http://HOST:PORT/ (default: "
                             "$RIVERBRIDGE_WEB_ROOT, else the repository's web/dist)")
    return parser


def config_from_args(args: argparse.Namespace) -> BridgeConfig:
    return BridgeConfig(
        host=args.host, port=args.port, max_message_size=args.max_message_size,
        fragment_timeout_s=args.fragment_timeout, call_timeout_s=args.call_timeout,
        topics_glob=tuple(args.topics_glob), services_glob=tuple(args.services_glob),
        send_buffer_bytes=args.send_buffer, interface_dirs=tuple(args.interfaces),
        offload_threshold_bytes=args.offload_threshold,
        web_root=args.web_root,
    )


async def serve_until_signalled(config: BridgeConfig) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        async with run_bridge(config) as running:
            logger.info("listening on ws://%s:%d", config.host, running.port)
            tune_process()
            freeze_startup_heap()
            await stop.wait()
            logger.info("shutting down")
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    for folder in args.interfaces:
        if not folder.is_dir():
            parser.error(f"argument --interfaces: {folder} is not a directory")
    try:
        config = config_from_args(args)
    except ValidationError as exc:
        parser.error(str(exc))
    logging.basicConfig(level=args.log_level.upper(),
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logger.setLevel(logging.INFO)  # the "listening on" line is always printed
    # websockets logs every connection and HTTP request at INFO; keep that for --log-level debug.
    websockets_level = logging.DEBUG if args.log_level == "debug" else logging.WARNING
    logging.getLogger("websockets").setLevel(websockets_level)
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(serve_until_signalled(config))
    return 0
