"""``python -m guidance`` / ``riverbridge guide``: run guidance and control against a bridge."""

from __future__ import annotations

import argparse
import logging

from clients.node.cli import add_node_arguments, run_node
from guidance.config import GuidanceConfig, load_config
from guidance.node import serve

log = logging.getLogger("guidance")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m guidance",
        description="Follow the route, avoid navigation's obstacles and command /cmd_wrench "
        "for the simulated vessel, as a rosbridge client.",
    )
    add_node_arguments(parser, "[route], [speed], [avoidance], [control], [inputs]")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run until SIGINT/SIGTERM (or ``--duration``); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    args = build_parser().parse_args(argv)
    return run_node(
        args,
        log,
        load_config,
        GuidanceConfig,
        lambda config, stop: serve(
            args.bridge,
            config,
            stop,
            encoding=args.encoding,
            connect_timeout_s=args.connect_timeout,
        ),
    )
