"""``python -m navigation`` / ``riverbridge nav``: run the navigation service against a bridge."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal

from clients import ConnectionFailed
from navigation.config import NavigationConfig, load_config
from navigation.node import serve

log = logging.getLogger("navigation")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m navigation",
        description="LIDAR clustering, radar CFAR, camera lines and the fused obstacle map, "
        "as a rosbridge client.",
    )
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument("--config", help="TOML file with [lidar], [cfar], [camera] ... tables")
    parser.add_argument("--encoding", choices=("cbor", "json"), default="cbor")
    parser.add_argument("--log-level", default="INFO")
    return parser


async def _run(url: str, config: NavigationConfig, encoding: str) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        await serve(url, config, stop, encoding=encoding)  # type: ignore[arg-type]
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run until SIGINT/SIGTERM; 0 on a clean stop, 2 on a bad config, 1 when
    the bridge cannot be reached."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    try:
        config = load_config(args.config) if args.config else NavigationConfig()
    except (OSError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        log.error("cannot use config %s: %s", args.config, exc)
        return 2
    try:
        asyncio.run(_run(args.bridge, config, args.encoding))
    except ConnectionFailed as exc:
        log.error("cannot reach the bridge at %s: %s", args.bridge, exc)
        return 1
    return 0
