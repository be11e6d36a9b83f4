"""``python -m guidance`` / ``riverbridge guide``: run guidance and control against a bridge."""

from __future__ import annotations

from clients.node.cli import node_main
from guidance.config import GuidanceConfig, load_config
from guidance.node import serve


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run until SIGINT/SIGTERM (or ``--duration``); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    return node_main(
        argv,
        prog="python -m guidance",
        description="Follow the route, avoid navigation's obstacles and command /cmd_wrench "
        "for the simulated vessel, as a rosbridge client.",
        config_tables="[route], [speed], [avoidance], [control], [inputs]",
        load_config=load_config,
        default=GuidanceConfig,
        serve=serve,
    )
