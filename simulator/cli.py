"""`python -m simulator` / `riverbridge sim`: run the simulator against a rosbridge server."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal

from clients import ConnectionFailed
from simulator.config import SimConfig, load_config
from simulator.node import serve

log = logging.getLogger("simulator")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m simulator",
        description="The vessel simulator (scene, dynamics, LIDAR, radar, camera, IMU, GNSS) "
        "as a rosbridge client.",
    )
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument("--config", help="TOML file with [scene], [vessel], [lidar] ... tables")
    parser.add_argument("--encoding", choices=("cbor", "json"), default="cbor")
    parser.add_argument("--duration", type=float, default=0.0,
                        help="stop after this many seconds (0: run until SIGINT/SIGTERM)")
    parser.add_argument("--connect-timeout", type=float, default=10.0,
                        help="seconds to keep retrying the first connection")
    parser.add_argument("--log-level", default="INFO")
    return parser


async def _run(url: str, cfg: SimConfig, encoding: str, duration_s: float,
               connect_timeout_s: float) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop.set)
        except (RuntimeError, ValueError):  # not the main thread (e.g. called from a test)
            break
    if duration_s > 0:
        loop.call_later(duration_s, stop.set)
    try:
        await serve(url, cfg, stop, encoding=encoding,  # type: ignore[arg-type]
                    connect_timeout_s=connect_timeout_s)
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def main(argv: list[str] | None = None) -> int:
    """Parse `argv` and run; 0 on a clean stop, 2 on a bad config, 1 when the bridge cannot
    be reached."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    try:
        cfg = load_config(args.config) if args.config else SimConfig()
    except (OSError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        log.error("cannot use config %s: %s", args.config, exc)
        return 2
    try:
        asyncio.run(_run(args.bridge, cfg, args.encoding, args.duration, args.connect_timeout))
    except ConnectionFailed as exc:
        log.error("cannot reach the bridge at %s: %s", args.bridge, exc)
        return 1
    return 0
