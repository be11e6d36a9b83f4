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
from schemas.bridge_config import GROUPS, BridgeConfig
from schemas.options import add_options, passed_through, spelled

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


# The bridge's options `up` passes through, in the order the bridge gets them; each is
# written once, on its `BridgeConfig` field (schemas.bridge_config).
BRIDGE_OPTIONS = (
    "auth_secret",
    "certfile",
    "keyfile",
    "allowed_origins",
    "max_clients",
    "dds",
    "dds_domain",
    "dds_interface",
    "dds_peers",
    "dds_parameters",
    "distro",
    "roles",
    "audit_log",
    "zenoh",
    "zenoh_listen",
    "zenoh_connect",
    "zenoh_config",
    "zenoh_distro",
)
PASSED = " (passed to the bridge)"


def build_parser() -> argparse.ArgumentParser:
    defaults = LaunchConfig()
    parser = argparse.ArgumentParser(
        prog="riverbridge up",
        description="Run the bridge, the simulator and the navigation service as three local "
        "processes with merged, prefixed logs, until Ctrl-C/SIGTERM or until one of them dies.",
        epilog="With --auth-secret-file or --certfile the simulator and navigation authenticate "
        "with that secret and trust that certificate (it must name the host they connect to, "
        "e.g. 127.0.0.1).",
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
        "--autopilot",
        action="store_true",
        help="also run guidance and control, which steers the vessel (docs/guidance.md)",
    )
    parser.add_argument(
        "--guidance-config", type=_toml_file, metavar="FILE", help="guidance TOML configuration"
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
    groups = {spell.option.group for spell in spelled(BridgeConfig, BRIDGE_OPTIONS)}
    add_options(
        parser,
        BridgeConfig,
        [title for title in GROUPS if title in groups],
        names=BRIDGE_OPTIONS,
        passing=PASSED,
    )
    return parser


def config_from_args(args: argparse.Namespace) -> LaunchConfig:
    return LaunchConfig(
        host=args.host,
        port=args.port,
        encoding=args.encoding,
        sim_config=args.sim_config,
        nav_config=args.nav_config,
        autopilot=args.autopilot,
        guidance_config=args.guidance_config,
        startup_timeout_s=args.startup_timeout,
        stop_timeout_s=args.stop_timeout,
        restart=args.restart,
        auth_secret_file=args.auth_secret,
        certfile=args.certfile,
        bridge_args=passed_through(args, BridgeConfig, BRIDGE_OPTIONS),
    )


async def _supervise(
    config: LaunchConfig, output: PrefixedOutput, extra: tuple[Component, ...] = ()
) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in STOP_SIGNALS:
        loop.add_signal_handler(sig, stop.set)

    parts = "four" if config.autopilot else "three"

    def announce(url: str) -> None:
        output.write("up", f"all {parts} ready; connect to {url} (Ctrl-C stops)")

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
