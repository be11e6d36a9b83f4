"""`python -m simulator` / `riverbridge sim`: run the simulator against a rosbridge server."""

from __future__ import annotations

import argparse
import logging

from clients.node.cli import add_node_arguments, run_node
from simulator.config import SimConfig, load_config
from simulator.node import serve

log = logging.getLogger("simulator")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m simulator",
        description="The vessel simulator (scene, dynamics, LIDAR, radar, camera, IMU, GNSS) "
        "as a rosbridge client.",
    )
    add_node_arguments(parser, "[scene], [vessel], [lidar] ...")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Parse `argv` and run until SIGINT/SIGTERM (or `--duration`); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    args = build_parser().parse_args(argv)
    return run_node(
        args,
        log,
        load_config,
        SimConfig,
        lambda cfg, stop: serve(
            args.bridge, cfg, stop, encoding=args.encoding, connect_timeout_s=args.connect_timeout
        ),
    )
