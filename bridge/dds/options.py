"""The bridge's DDS command-line options (`--dds`, `--domain`, ...); no Cyclone import here.

Defaults come from the environment where ROS 2 or a container puts them: `ROS_DOMAIN_ID`
(ROS 2's own variable), and `RIVERBRIDGE_DDS`, `RIVERBRIDGE_DDS_INTERFACE`,
`RIVERBRIDGE_DDS_PEERS` (comma-separated) for docker compose. Options win over variables.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping
from typing import Any

from bridge.dds.cyclone_xml import MULTICAST_MODES, CycloneSettings, cyclone_xml, peers_from_text

MAX_DOMAIN = 232
_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"", "0", "false", "no", "off"}


def domain_id(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a domain id: {text!r}") from None
    if not 0 <= value <= MAX_DOMAIN:
        raise argparse.ArgumentTypeError(f"must be 0..{MAX_DOMAIN}, got {value}")
    return value


def env_defaults(env: Mapping[str, str]) -> dict[str, Any]:
    """Option defaults from the environment; raises ValueError naming a bad variable."""
    flag = env.get("RIVERBRIDGE_DDS", "").strip().lower()
    if flag not in _TRUE | _FALSE:
        raise ValueError(f"RIVERBRIDGE_DDS must be 1/0, true/false, yes/no, got {flag!r}")
    try:
        domain = domain_id(env.get("ROS_DOMAIN_ID", "0").strip() or "0")
    except argparse.ArgumentTypeError as exc:
        raise ValueError(f"ROS_DOMAIN_ID {exc}") from None
    return {
        "dds": flag in _TRUE,
        "domain": domain,
        "dds_interface": env.get("RIVERBRIDGE_DDS_INTERFACE", "").strip() or "lo",
        "dds_peer": list(peers_from_text([env.get("RIVERBRIDGE_DDS_PEERS", "")])),
    }


def add_dds_options(parser: argparse.ArgumentParser, env: Mapping[str, str] | None = None) -> None:
    """Add the DDS group to the bridge's parser (defaults from `env`, default os.environ)."""
    try:
        defaults = env_defaults(os.environ if env is None else env)
    except ValueError as exc:
        parser.error(str(exc))
    group = parser.add_argument_group("ROS 2 over DDS (docs/ros2.md)")
    group.add_argument(
        "--dds",
        action="store_true",
        default=defaults["dds"],
        help="join a ROS 2 DDS domain with Cyclone DDS and mirror topics and "
        "services both ways ($RIVERBRIDGE_DDS)",
    )
    group.add_argument(
        "--domain",
        type=domain_id,
        default=defaults["domain"],
        metavar="N",
        help=f"DDS domain id 0..{MAX_DOMAIN} (default $ROS_DOMAIN_ID or 0; now %(default)s)",
    )
    group.add_argument(
        "--dds-interface",
        default=defaults["dds_interface"],
        metavar="NAME",
        help="the only network interface DDS may use (default %(default)s; "
        "$RIVERBRIDGE_DDS_INTERFACE)",
    )
    group.add_argument(
        "--dds-peer",
        action="append",
        default=None,
        metavar="ADDR",
        help="unicast discovery peer, repeatable or comma-separated (default "
        "$RIVERBRIDGE_DDS_PEERS, else 127.0.0.1 on lo)",
    )
    parser.set_defaults(dds_env_peers=defaults["dds_peer"])
    group.add_argument(
        "--dds-multicast",
        choices=MULTICAST_MODES,
        default="false",
        help="multicast on that interface: false, spdp (discovery only) or true "
        "(default %(default)s)",
    )
    group.add_argument(
        "--dds-node",
        default="",
        metavar="NAME",
        help="the bridge's ROS 2 node name on the domain (default /riverbridge_<id>)",
    )
    group.add_argument(
        "--dds-untuned",
        action="store_true",
        help="Cyclone's own socket buffers and writer cache limits instead of "
        "the bridge's large-sample settings (to measure them)",
    )
    group.add_argument(
        "--print-dds-config",
        action="store_true",
        help="print the Cyclone DDS XML these options give (for CYCLONEDDS_URI "
        "of ROS 2 nodes that should meet the bridge) and exit",
    )


def dds_config_fields(args: argparse.Namespace) -> dict[str, Any]:
    """The BridgeConfig fields of the parsed DDS options."""
    return {
        "dds": args.dds,
        "dds_domain": args.domain,
        "dds_interface": args.dds_interface,
        "dds_peers": peers(args),
        "dds_multicast": args.dds_multicast,
        "dds_node": args.dds_node,
        "dds_tuned": not args.dds_untuned,
    }


def peers(args: argparse.Namespace) -> tuple[str, ...]:
    return peers_from_text(args.dds_peer) if args.dds_peer else tuple(args.dds_env_peers)


def print_config(args: argparse.Namespace) -> str:
    """The XML for `--print-dds-config` (raises ValueError for a bad interface or peer)."""
    settings = CycloneSettings(args.dds_interface, peers(args), args.dds_multicast)
    return cyclone_xml(settings, tuned=not args.dds_untuned)
