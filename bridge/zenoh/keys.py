"""rmw_zenoh's data key expressions and type identities (docs/zenoh.md). Pure.

A topic `/imu/data` of `sensor_msgs/msg/Imu` in domain 0 is published on
`0/imu/data/sensor_msgs::msg::dds_::Imu_/RIHS01_<64 hex>`; a service's queryable is keyed the
same way with its service type (`std_srvs::srv::dds_::SetBool_`). The last element is the
type hash: RIHS01 from Jazzy on, the literal `TypeHashNotSupported` on Humble.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from bridge.dds.naming import type_from_dds, type_to_dds
from schemas.registry import TypeRegistry

Distro = Literal["humble", "jazzy", "kilted", "rolling"]
DISTROS: tuple[Distro, ...] = ("humble", "jazzy", "kilted", "rolling")
# What Humble's rmw_zenoh puts where later distros put the RIHS01 hash.
TYPE_HASH_UNSUPPORTED = "TypeHashNotSupported"
# rmw_zenoh writes `/` inside one key element as `%` (liveliness tokens; `%` alone is "/").
SLASH_REPLACEMENT = "%"


class KeyProblem(ValueError):
    """A key expression that is not an rmw_zenoh data key, or names a type we do not know."""


@dataclass(frozen=True)
class DataKey:
    """What a data key expression says: domain, absolute ROS name, ROS type, type hash."""

    domain: int
    name: str  # "/imu/data"
    type_name: str  # "sensor_msgs/msg/Imu" (a service's: "std_srvs/srv/SetBool")
    type_hash: str  # "RIHS01_…" or TYPE_HASH_UNSUPPORTED


def mangle(name: str) -> str:
    """`/robot1/chatter` -> `%robot1%chatter`; an empty name is `%` (a key element is never
    empty)."""
    return name.replace("/", SLASH_REPLACEMENT) or SLASH_REPLACEMENT


def demangle(element: str) -> str:
    return element.replace(SLASH_REPLACEMENT, "/")


def data_key(domain: int, name: str, type_name: str, type_hash: str) -> str:
    """The key expression rmw_zenoh publishes, subscribes or queries a ROS name on."""
    stripped = name.strip("/")
    if not stripped or "*" in stripped or "$" in stripped or "//" in stripped:
        raise KeyProblem(f"{name!r} is not a ROS name usable in a key expression")
    return f"{domain}/{stripped}/{type_to_dds(type_name)}/{type_hash}"


def parse_data_key(key: str) -> DataKey:
    """The inverse of `data_key` (KeyProblem if `key` is not one)."""
    parts = key.split("/")
    if len(parts) < 4 or not parts[0].isdigit() or not all(parts):
        raise KeyProblem(f"{key!r} is not <domain>/<name>/<type>/<hash>")
    type_name = type_from_dds(parts[-2])
    if type_name is None:
        raise KeyProblem(f"{parts[-2]!r} in {key!r} is not a ROS 2 DDS type name")
    return DataKey(int(parts[0]), "/" + "/".join(parts[1:-2]), type_name, parts[-1])


def type_hash(registry: TypeRegistry, type_name: str, distro: Distro) -> str:
    """The hash element of `type_name`'s keys on `distro`: RIHS01 as rosbags computes it (the
    DDS plug-in's `typehash=` user data is the same), TYPE_HASH_UNSUPPORTED on Humble and for
    types rosbags cannot hash (service types: rmw_zenoh hashes the request, response and
    event together, which rosbags does not do)."""
    if distro == "humble":
        return TYPE_HASH_UNSUPPORTED
    try:
        return str(registry.typestore.hash_rihs01(type_name))
    except Exception:  # a service type, or a type rosbags' store does not hold
        return TYPE_HASH_UNSUPPORTED
