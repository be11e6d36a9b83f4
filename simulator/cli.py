"""`python -m simulator` / `riverbridge sim`: run the simulator against a rosbridge server."""

from __future__ import annotations

from clients.node.cli import node_main
from simulator.config import SimConfig, load_config
from simulator.node import serve


def main(argv: list[str] | None = None) -> int:
    """Parse `argv` and run until SIGINT/SIGTERM (or `--duration`); 0 on a clean stop, 2 on a
    bad config, 1 when the bridge cannot be reached."""
    return node_main(
        argv,
        prog="python -m simulator",
        description="The vessel simulator (scene, dynamics, LIDAR, radar, camera, IMU, GNSS) "
        "as a rosbridge client.",
        config_tables="[scene], [vessel], [lidar] ...",
        load_config=load_config,
        default=SimConfig,
        serve=serve,
    )
