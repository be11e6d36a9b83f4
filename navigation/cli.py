"""``python -m navigation`` / ``riverbridge nav``: run the navigation service against a bridge."""

from __future__ import annotations

import argparse
import logging

from clients.node.cli import add_node_arguments, run_node
from navigation.config import NavigationConfig, load_config
from navigation.node import serve

log = logging.getLogger("navigation")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m navigation",
        description="LIDAR clustering, radar CFAR, camera lines and the fused obstacle map, "
        "as a rosbridge client.",
    )
    add_node_arguments(parser, "[lidar], [cfar], [camera] ...")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run until SIGINT/SIGTERM (or ``--duration``); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    args = build_parser().parse_args(argv)
    return run_node(
        args,
        log,
        load_config,
        NavigationConfig,
        lambda config, stop: serve(
            args.bridge,
            config,
            stop,
            encoding=args.encoding,
            connect_timeout_s=args.connect_timeout,
        ),
    )
