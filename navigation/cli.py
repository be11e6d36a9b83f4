"""``python -m navigation`` / ``riverbridge nav``: run the navigation service against a bridge."""

from __future__ import annotations

from clients.node.cli import node_main
from navigation.config import NavigationConfig, load_config
from navigation.node import serve


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv``, run until SIGINT/SIGTERM (or ``--duration``); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    return node_main(
        argv,
        prog="python -m navigation",
        description="LIDAR clustering, radar CFAR, camera lines and the fused obstacle map, "
        "as a rosbridge client.",
        config_tables="[lidar], [cfar], [camera] ...",
        load_config=load_config,
        default=NavigationConfig,
        serve=serve,
    )
