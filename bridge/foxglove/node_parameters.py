"""ROS 2 nodes' parameters in Foxglove's shape: `/talker.gain` is parameter `gain` of `/talker`.

foxglove_bridge (ROS 2) names another node's parameter `<fully qualified node>.<param>`,
split at the first dot (ROS 2 node names hold no dot; parameter names may), and reads and
sets it through that node's `rcl_interfaces` services. So does this bridge: a name is a
node's when `<node>/get_parameters` is in the graph (a DDS node through the mirror, or a
client that provides it); any other name is one of the bridge's own (rosapi's). Values cross
as Foxglove's: doubles carry `type: "float64"` (so 2.0 stays a double), byte arrays are
base64 with `type: "byte_array"`. Pure: names, values and service requests in and out.
"""

from __future__ import annotations

import base64
import binascii
from collections.abc import Container, Iterable
from typing import Any

from bridge.foxglove import wire
from bridge.rosapi.node_params import NOT_SET, VALUE_FIELDS, kind_of
from schemas.safety import echo
from schemas.values import Message

SEPARATOR = "."
GET, LIST, SET = "get_parameters", "list_parameters", "set_parameters"
SERVICE_TYPES = {
    GET: "rcl_interfaces/srv/GetParameters",
    LIST: "rcl_interfaces/srv/ListParameters",
    SET: "rcl_interfaces/srv/SetParameters",
}
DOUBLE, BYTE_ARRAY, DOUBLE_ARRAY = 3, 5, 8  # rcl_interfaces/msg/ParameterType


def split_name(name: str, services: Container[str]) -> tuple[str, str] | None:
    """`/talker.gain` -> (`/talker`, `gain`) when `/talker/get_parameters` is in `services`;
    None for a name of the bridge's own."""
    node, dot, param = name.partition(SEPARATOR)
    if not dot or not param or not node.startswith("/") or len(node) < 2:
        return None
    return (node, param) if f"{node}/{GET}" in services else None


def full_name(node: str, param: str) -> str:
    return f"{node}{SEPARATOR}{param}"


def parameter_nodes(services: Container[str], nodes: Iterable[str]) -> list[str]:
    """The nodes of `nodes` that list and get their parameters (as foxglove_bridge asks)."""
    return sorted(n for n in nodes if f"{n}/{LIST}" in services and f"{n}/{GET}" in services)


def service_nodes(services: Iterable[str]) -> set[str]:
    """Nodes named by the `<node>/get_parameters` services among `services`."""
    suffix = f"/{GET}"
    return {name[: -len(suffix)] for name in services if name.endswith(suffix) and len(name) > 1}


def by_node(named: Iterable[tuple[str, str]]) -> dict[str, list[str]]:
    """(node, param) pairs grouped by node, in their order."""
    grouped: dict[str, list[str]] = {}
    for node, param in named:
        grouped.setdefault(node, []).append(param)
    return grouped


def to_foxglove(node: str, param: str, value: Message) -> dict[str, Any] | None:
    """A ParameterValue as a Foxglove parameter (None when NOT_SET: the node has none)."""
    kind = int(value.get("type", NOT_SET))
    field = VALUE_FIELDS.get(kind)
    if field is None:
        return None
    plain = value.get(field)
    parameter: dict[str, Any] = {"name": full_name(node, param)}
    if kind == BYTE_ARRAY:
        parameter["value"] = base64.b64encode(bytes(plain or b"")).decode()
        parameter["type"] = "byte_array"
        return parameter
    tolist = getattr(plain, "tolist", None)
    parameter["value"] = tolist() if tolist is not None else plain
    if kind in (DOUBLE, DOUBLE_ARRAY):
        parameter["type"] = "float64" if kind == DOUBLE else "float64_array"
    return parameter


def to_ros(parameter: wire.Parameter) -> Message:
    """A Foxglove parameter's value as a ParameterValue; ValueError says why it cannot be one."""
    value, kind = parameter.value, parameter.type
    if kind == "byte_array":
        try:
            return {
                "type": BYTE_ARRAY,
                VALUE_FIELDS[BYTE_ARRAY]: base64.b64decode(value, validate=True),
            }
        except (binascii.Error, TypeError) as exc:
            raise ValueError("byte_array value is not base64") from exc
    if kind == "float64" and _number(value):
        return {"type": DOUBLE, VALUE_FIELDS[DOUBLE]: float(value)}
    if kind == "float64_array" and isinstance(value, list) and all(map(_number, value)):
        return {"type": DOUBLE_ARRAY, VALUE_FIELDS[DOUBLE_ARRAY]: [float(v) for v in value]}
    found = kind_of(value) if kind in (None, "float64", "float64_array") else None
    if found is None:
        raise ValueError(f"a ROS 2 parameter cannot hold {echo(value, 80)} (type {echo(kind, 30)})")
    return {"type": found, VALUE_FIELDS[found]: value}


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def set_failures(node: str, params: list[str], answer: Message | str) -> list[tuple[str, str]]:
    """The parameters of `node` its SetParameters answer (or the failure text of the call)
    says were not set, each with a line saying why."""
    if isinstance(answer, str):
        return [(p, f"setting {full_name(node, p)} failed: {answer}") for p in params]
    results = list(answer.get("results") or [])
    failed = []
    for index, param in enumerate(params):
        result = results[index] if index < len(results) else {"reason": "no result"}
        if not result.get("successful"):
            reason = f"setting {full_name(node, param)} failed: {result.get('reason')}"
            failed.append((param, reason))
    return failed
