"""`python -m bridge`: run the rosbridge v2 websocket server until SIGINT/SIGTERM."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import os
import signal
import ssl
from pathlib import Path

from pydantic import SecretStr, ValidationError

from bridge.access import scheme, tls_context
from bridge.config import AUTH_SECRET_ENV, MIB, MIN_SEND_BUFFER, BridgeConfig
from bridge.dds.options import add_dds_options, dds_config_fields, print_config
from bridge.errors import DdsStartError
from bridge.server import run_bridge
from schemas.rosauth import read_secret
from schemas.runtime import event_loop
from schemas.runtime.process import freeze_startup_heap, tune_process

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
    parser.add_argument(
        "--port",
        type=port_number,
        default=defaults.port,
        help="TCP port; 0 picks a free one (default %(default)s)",
    )
    parser.add_argument(
        "--max-message-size",
        type=positive_int,
        default=defaults.max_message_size,
        help="inbound frame limit in bytes; larger frames close with 1009 "
        f"(default {defaults.max_message_size // MIB} MiB)",
    )
    parser.add_argument(
        "--fragment-timeout",
        type=positive_float,
        default=defaults.fragment_timeout_s,
        help="seconds to wait for missing fragments (default %(default)s)",
    )
    parser.add_argument(
        "--call-timeout",
        type=positive_float,
        default=defaults.call_timeout_s,
        help="default call_service timeout in seconds (default %(default)s)",
    )
    parser.add_argument(
        "--topics-glob",
        action="append",
        default=[],
        metavar="PATTERN",
        help="allow only topics matching this fnmatch pattern (repeatable)",
    )
    parser.add_argument(
        "--services-glob",
        action="append",
        default=[],
        metavar="PATTERN",
        help="allow only services matching this fnmatch pattern (repeatable)",
    )
    parser.add_argument(
        "--actions-glob",
        action="append",
        default=[],
        metavar="PATTERN",
        help="allow only actions matching this fnmatch pattern (repeatable; "
        "default: the --services-glob patterns)",
    )
    parser.add_argument(
        "--send-buffer",
        type=buffer_bytes,
        default=defaults.send_buffer_bytes,
        metavar="BYTES",
        help="bytes a client may leave untaken before each of its topics loses "
        "its oldest waiting message "
        f"(default {defaults.send_buffer_bytes // MIB} MiB)",
    )
    parser.add_argument(
        "--offload-threshold",
        type=positive_int,
        default=defaults.offload_threshold_bytes,
        metavar="BYTES",
        help="payloads at least this large are decoded and encoded in a worker "
        "thread, off the event loop (default %(default)s)",
    )
    parser.add_argument(
        "--log-level", default="info", choices=["debug", "info", "warning", "error", "critical"]
    )
    parser.add_argument(
        "--interfaces",
        action="append",
        default=[],
        type=Path,
        metavar="DIR",
        help="extra folder of <pkg>/{msg,srv,action}/ definitions (repeatable)",
    )
    secret_env = os.environ.get(AUTH_SECRET_ENV)
    parser.add_argument(
        "--auth-secret-file",
        type=Path,
        metavar="FILE",
        default=Path(secret_env) if secret_env else None,
        help="require rosauth's auth op, checked against the secret on the "
        f"file's first line, before any other op (default: "
        f"${AUTH_SECRET_ENV})",
    )
    parser.add_argument(
        "--certfile",
        type=Path,
        default=None,
        metavar="FILE",
        help="TLS certificate chain (PEM): serve wss:// and https://",
    )
    parser.add_argument(
        "--keyfile",
        type=Path,
        default=None,
        metavar="FILE",
        help="TLS private key (PEM) of --certfile",
    )
    parser.add_argument(
        "--allowed-origins",
        nargs="+",
        action="extend",
        default=[],
        metavar="GLOB",
        help="browser Origins allowed to open a websocket "
        "(fnmatch, e.g. 'https://*.example.org'); others get 403; clients "
        "without Origin are not affected",
    )
    parser.add_argument(
        "--max-clients",
        type=positive_int,
        default=None,
        metavar="N",
        help="refuse handshakes (503) while N clients are connected",
    )
    parser.add_argument(
        "--reply-budget",
        type=positive_int,
        default=defaults.reply_budget_bytes,
        metavar="BYTES",
        help="unread answers (never dropped) a client may "
        "leave before it is closed with 1008 (default 32 MiB)",
    )
    parser.add_argument(
        "--web-root",
        type=Path,
        default=None,
        metavar="DIR",
        help="built web dashboard to serve at http://HOST:PORT/ (default: "
        "$RIVERBRIDGE_WEB_ROOT, else the repository's web/dist)",
    )
    add_dds_options(parser)
    return parser


def config_from_args(args: argparse.Namespace) -> BridgeConfig:
    return BridgeConfig(
        host=args.host,
        port=args.port,
        max_message_size=args.max_message_size,
        fragment_timeout_s=args.fragment_timeout,
        call_timeout_s=args.call_timeout,
        topics_glob=tuple(args.topics_glob),
        services_glob=tuple(args.services_glob),
        actions_glob=tuple(args.actions_glob),
        send_buffer_bytes=args.send_buffer,
        interface_dirs=tuple(args.interfaces),
        offload_threshold_bytes=args.offload_threshold,
        web_root=args.web_root,
        auth_secret=None
        if args.auth_secret_file is None
        else SecretStr(read_secret(args.auth_secret_file)),
        certfile=args.certfile,
        keyfile=args.keyfile,
        allowed_origins=tuple(args.allowed_origins),
        max_clients=args.max_clients,
        reply_budget_bytes=args.reply_budget,
        **dds_config_fields(args),
    )


async def serve_until_signalled(config: BridgeConfig) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        async with run_bridge(config) as running:
            logger.info(
                "listening on %s://%s:%d (event loop: %s)",
                scheme(config),
                config.host,
                running.port,
                event_loop.running_loop_name(),
            )
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
    for option in ("auth_secret_file", "certfile", "keyfile"):
        path = getattr(args, option)
        if path is not None and not path.is_file():
            parser.error(f"argument --{option.replace('_', '-')}: no such file: {path}")
    try:
        config = config_from_args(args)
        tls_context(config)  # a certificate that does not load fails here, not at start-up
    except (ValidationError, ValueError, OSError, ssl.SSLError) as exc:
        parser.error(str(exc))
    if args.print_dds_config:
        print(print_config(args))
        return 0
    try:
        loop_name = event_loop.chosen_loop()
    except event_loop.EventLoopChoiceError as exc:
        parser.error(str(exc))
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    logger.setLevel(logging.INFO)  # the "listening on" line is always printed
    # websockets logs every connection and HTTP request at INFO; keep that for --log-level debug.
    websockets_level = logging.DEBUG if args.log_level == "debug" else logging.WARNING
    logging.getLogger("websockets").setLevel(websockets_level)
    with contextlib.suppress(KeyboardInterrupt):
        try:
            event_loop.run(serve_until_signalled(config), loop_name)
        except DdsStartError as exc:
            logger.error("%s", exc)
            return 1
    return 0
