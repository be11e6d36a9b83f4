"""`python -m bridge`: run the rosbridge v2 websocket server until SIGINT/SIGTERM.

Every option but `--log-level` and `--print-dds-config` is a `BridgeConfig` field's, written
once in `schemas.bridge_config` (`schemas.options` derives the arguments, their grouping,
defaults, bounds and error messages from it).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import os
import signal
import ssl
from collections.abc import Mapping

from pydantic import ValidationError

from bridge.access import scheme, tls_context
from bridge.compose import run_bridge
from bridge.config import BridgeConfig
from bridge.dds.cyclone_xml import CycloneSettings, cyclone_xml
from bridge.errors import DdsStartError, ZenohStartError
from schemas.bridge_config import GROUPS
from schemas.options import add_options, config_values, invalid_options
from schemas.runtime import event_loop, native
from schemas.runtime.process import freeze_startup_heap, tune_process

logger = logging.getLogger("bridge.cli")

LOG_LEVELS = ("debug", "info", "warning", "error", "critical")


def build_parser(env: Mapping[str, str] | None = None) -> argparse.ArgumentParser:
    """The options of `BridgeConfig`, defaults from `env` (default os.environ) where an
    option names a variable, and the two that are not configuration."""
    parser = argparse.ArgumentParser(
        prog="python -m bridge",
        description="Run the rosbridge v2 websocket server until SIGINT/SIGTERM.",
    )
    add_options(parser, BridgeConfig, GROUPS, env=os.environ if env is None else env)
    parser.add_argument("--log-level", default="info", choices=LOG_LEVELS)
    parser.add_argument(
        "--print-dds-config",
        action="store_true",
        help="print the Cyclone DDS XML these options give (for CYCLONEDDS_URI of ROS 2 "
        "nodes that should meet the bridge) and exit",
    )
    return parser


def config_from_args(args: argparse.Namespace) -> BridgeConfig:
    """The configuration the parsed options give (pydantic's ValidationError if refused)."""
    return BridgeConfig(**config_values(args, BridgeConfig))


def check_audit_log(config: BridgeConfig) -> None:
    """`--audit-log` must be a file the bridge can append to (ValueError naming it)."""
    if config.audit_log is None:
        return
    try:
        with config.audit_log.open("a", encoding="utf-8"):
            pass
    except OSError as exc:
        raise ValueError(
            f"argument --audit-log: cannot append to {config.audit_log}: {exc}"
        ) from None


def dds_config_xml(config: BridgeConfig) -> str:
    """`--print-dds-config`: the XML (ValueError for a bad interface or peer)."""
    settings = CycloneSettings(config.dds_interface, config.dds_peers, config.dds_multicast)
    return cyclone_xml(settings, tuned=config.dds_tuned)


async def serve_until_signalled(config: BridgeConfig) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        async with run_bridge(config) as running:
            logger.info(
                "listening on %s://%s:%d (event loop: %s, hot path: %s)",
                scheme(config),
                config.host,
                running.port,
                event_loop.running_loop_name(),
                "compiled" if native.active_build() else "Python",
            )
            tune_process()
            freeze_startup_heap()
            await stop.wait()
            logger.info("shutting down")
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def check_zenoh_config(config: BridgeConfig) -> None:
    """ValueError naming the problem if `--zenoh-config`'s file is not a Zenoh configuration."""
    if config.zenoh and config.zenoh_config is not None:
        from bridge.zenoh.session import ZenohSettings, session_config

        settings = ZenohSettings(config.zenoh_listen, config.zenoh_connect, config.zenoh_config)
        session_config(settings)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        config = config_from_args(args)
        tls_context(config)  # a certificate that does not load fails here, not at start-up
        check_zenoh_config(config)  # a Zenoh configuration file Zenoh refuses fails here too
        check_audit_log(config)
    except ValidationError as exc:
        parser.error(invalid_options(exc, BridgeConfig))
    except (ValueError, OSError, ssl.SSLError) as exc:
        parser.error(str(exc))
    if args.print_dds_config:
        try:
            print(dds_config_xml(config))
        except ValueError as exc:
            parser.error(str(exc))
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
        except (DdsStartError, ZenohStartError) as exc:
            logger.error("%s", exc)
            return 1
    return 0
