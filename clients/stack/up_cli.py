"""``riverbridge up`` / ``python -m clients.stack.up_cli``: bridge, simulator and navigation as
three local processes, with merged, prefixed logs, until Ctrl-C/SIGTERM; a component that dies is
restarted (``--restart``, default on-failure) while the others keep running.

Exit codes: 0 after a clean stop on SIGINT/SIGTERM; 1 when a component died and was not
restarted (``--restart never``, or during start-up), did not become ready within
``--startup-timeout``, or did not stop cleanly; 2 for bad options.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
import sys
from pathlib import Path

from clients.node.child import Component
from clients.node.cli import positive_seconds
from clients.node.output import PrefixedLogHandler, PrefixedOutput
from clients.recording.components import recorder_component
from clients.recording.record_cli import output_file
from clients.stack.launcher import LaunchConfig, Supervisor, stack_components
from clients.stack.restarts import RESTART_MODES

log = logging.getLogger("clients.stack.launcher")

# Ctrl-C, `kill`/docker stop, and a closed terminal all mean "stop the three cleanly".
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be 0..65535 (0 picks a free port), got {value}")
    return value


def _toml_file(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return path.resolve()


def _existing_file(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return path.resolve()


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {value}")
    return value


def add_access_arguments(parser: argparse.ArgumentParser) -> None:
    """The bridge's access options, passed through (docs/bridge.md)."""
    parser.add_argument(
        "--auth-secret-file",
        type=_existing_file,
        metavar="FILE",
        help="the bridge requires rosauth's auth op with this secret; the "
        "simulator and navigation authenticate with it",
    )
    parser.add_argument(
        "--certfile",
        type=_existing_file,
        metavar="FILE",
        help="serve wss:// and https:// with this certificate (it must name "
        "the host the components connect to, e.g. 127.0.0.1)",
    )
    parser.add_argument(
        "--keyfile", type=_existing_file, metavar="FILE", help="private key of --certfile"
    )
    parser.add_argument(
        "--allowed-origins",
        nargs="+",
        default=[],
        metavar="GLOB",
        help="browser Origins allowed to connect (others get 403)",
    )
    parser.add_argument(
        "--max-clients",
        type=_positive_int,
        metavar="N",
        help="refuse websocket handshakes while N clients are connected",
    )


def build_parser() -> argparse.ArgumentParser:
    defaults = LaunchConfig()
    parser = argparse.ArgumentParser(
        prog="riverbridge up",
        description="Run the bridge, the simulator and the navigation service as three local "
        "processes with merged, prefixed logs, until Ctrl-C/SIGTERM or until one of them dies.",
    )
    parser.add_argument(
        "--host", default=defaults.host, help="address the bridge listens on (default %(default)s)"
    )
    parser.add_argument(
        "--port",
        type=_port,
        default=defaults.port,
        help="the bridge's TCP port; 0 picks a free one (default %(default)s)",
    )
    parser.add_argument(
        "--encoding",
        choices=("json", "cbor"),
        default=defaults.encoding,
        help="wire encoding of the simulator and navigation (default %(default)s)",
    )
    parser.add_argument(
        "--sim-config", type=_toml_file, metavar="FILE", help="simulator TOML configuration"
    )
    parser.add_argument(
        "--nav-config", type=_toml_file, metavar="FILE", help="navigation TOML configuration"
    )
    parser.add_argument(
        "--startup-timeout",
        type=positive_seconds,
        default=defaults.startup_timeout_s,
        metavar="S",
        help="seconds for all three to become ready (default %(default)s)",
    )
    parser.add_argument(
        "--record",
        type=output_file,
        metavar="FILE.mcap",
        help="also record every topic into this MCAP file (riverbridge record)",
    )
    parser.add_argument(
        "--stop-timeout",
        type=positive_seconds,
        default=defaults.stop_timeout_s,
        metavar="S",
        help="seconds per shutdown step (SIGINT, SIGTERM, SIGKILL; default %(default)s)",
    )
    parser.add_argument(
        "--restart",
        choices=RESTART_MODES,
        default=defaults.restart,
        help="restart a component that dies: on-failure (non-zero exit or a "
        "signal), always, or never (then up stops; default %(default)s)",
    )
    add_access_arguments(parser)
    add_dds_options(parser)
    return parser


def _domain(text: str) -> str:
    if not text.isdigit() or not 0 <= int(text) <= 232:
        raise argparse.ArgumentTypeError(f"must be a DDS domain id 0..232, got {text!r}")
    return text


def add_dds_options(parser: argparse.ArgumentParser) -> None:
    """The bridge's DDS options, passed through to it (docs/ros2.md)."""
    group = parser.add_argument_group("ROS 2 over DDS (passed to the bridge; docs/ros2.md)")
    group.add_argument(
        "--dds", action="store_true", help="the bridge joins a ROS 2 DDS domain with Cyclone DDS"
    )
    group.add_argument(
        "--domain",
        type=_domain,
        metavar="N",
        help="DDS domain id (bridge default: $ROS_DOMAIN_ID or 0)",
    )
    group.add_argument(
        "--dds-interface",
        metavar="NAME",
        help="the only network interface DDS may use (bridge default: lo)",
    )
    group.add_argument(
        "--dds-peer",
        action="append",
        default=[],
        metavar="ADDR",
        help="unicast discovery peer (repeatable)",
    )


def dds_bridge_args(args: argparse.Namespace) -> tuple[str, ...]:
    extra = ["--dds"] if args.dds else []
    if args.domain is not None:
        extra += ["--domain", args.domain]
    if args.dds_interface is not None:
        extra += ["--dds-interface", args.dds_interface]
    for peer in args.dds_peer:
        extra += ["--dds-peer", peer]
    return tuple(extra)


def config_from_args(args: argparse.Namespace) -> LaunchConfig:
    return LaunchConfig(
        host=args.host,
        port=args.port,
        encoding=args.encoding,
        sim_config=args.sim_config,
        nav_config=args.nav_config,
        startup_timeout_s=args.startup_timeout,
        stop_timeout_s=args.stop_timeout,
        restart=args.restart,
        auth_secret_file=args.auth_secret_file,
        certfile=args.certfile,
        keyfile=args.keyfile,
        allowed_origins=tuple(args.allowed_origins),
        max_clients=args.max_clients,
        bridge_args=dds_bridge_args(args),
    )


async def _supervise(
    config: LaunchConfig, output: PrefixedOutput, extra: tuple[Component, ...] = ()
) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in STOP_SIGNALS:
        loop.add_signal_handler(sig, stop.set)

    def announce(url: str) -> None:
        output.write("up", f"all three ready; connect to {url} (Ctrl-C stops)")

    try:
        supervisor = Supervisor(stack_components(config) + extra, config, output, on_ready=announce)
        return await supervisor.run(stop)
    finally:
        for sig in STOP_SIGNALS:
            loop.remove_signal_handler(sig)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if (args.certfile is None) != (args.keyfile is None):
        parser.error("argument --certfile/--keyfile: give both or neither")
    config = config_from_args(args)
    output = PrefixedOutput(sys.stdout)
    handler = PrefixedLogHandler(output)
    log.addHandler(handler)
    log.setLevel(logging.INFO)
    log.propagate = False
    try:
        extra = (recorder_component(args.record),) if args.record else ()
        return asyncio.run(_supervise(config, output, extra))
    finally:
        log.removeHandler(handler)


if __name__ == "__main__":
    sys.exit(main())
