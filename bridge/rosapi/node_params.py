"""rosapi parameters of other ROS 2 nodes: `/talker:gain` is parameter `gain` of `/talker`.

rosbridge's rosapi on ROS 2 names a node's parameter `node_name:param_name` and answers from
that node's `rcl_interfaces` services. So does the bridge: `get_param`, `set_param` and
`has_param` with such a name are forwarded (`Forward`) to `<node>/get_parameters` or
`<node>/set_parameters`, wherever that service lives (a DDS node through the DDS mirror, a
websocket client that provides it), with the core's call timeout; the node's answer is
translated back into the rosapi response. A node without those services in the graph keeps
its parameters in the bridge, as every name did before (`bridge.rosapi.param_services`).
`get_param_names` gathers every such node's `list_parameters` (`Gather`).
Values are JSON text both ways, as rosapi's are. Pure: request in, `Forward` out; response
in, rosapi values out.
"""

from __future__ import annotations

from typing import Any

from bridge.context import Context
from bridge.errors import RosapiError
from bridge.rosapi.common import Forward, Gather
from schemas import codec_json
from schemas.errors import DecodeError
from schemas.values import Message

# rcl_interfaces/msg/ParameterType: the field of ParameterValue holding each type's value.
VALUE_FIELDS = {
    1: "bool_value",
    2: "integer_value",
    3: "double_value",
    4: "string_value",
    5: "byte_array_value",
    6: "bool_array_value",
    7: "integer_array_value",
    8: "double_array_value",
    9: "string_array_value",
}
NOT_SET = 0


def node_param(name: str) -> tuple[str, str] | None:
    """`/talker:gain` -> (`/talker`, `gain`); None for a name of the bridge's own."""
    node, colon, param = name.partition(":")
    if not colon:
        return None
    if not node.strip("/") or not param:
        raise RosapiError(f"parameter name {name!r} must be node_name:param_name")
    return "/" + node.strip("/"), param


def served_param(ctx: Context, name: str, service: str) -> tuple[str, str] | None:
    """(node, parameter) of `name` if that node's `service` is in the graph, else None."""
    named = node_param(name)
    if named is None or f"{named[0]}/{service}" not in ctx.state.graph.services:
        return None
    return named


def value_json(value: Message) -> str:
    """A ParameterValue as JSON text (None for NOT_SET)."""
    field = VALUE_FIELDS.get(int(value.get("type", NOT_SET)))
    plain = _plain(value.get(field)) if field else None
    return codec_json.dumps(plain).decode()


def parameter_value(text: str) -> Message:
    """JSON text as the ParameterValue of the type the JSON has (rosapi's rule)."""
    try:
        plain = codec_json.loads(text.encode())
    except DecodeError as exc:
        raise RosapiError(f"value {text!r} is not JSON text: {exc}") from exc
    kind = kind_of(plain)
    if kind is None:
        raise RosapiError(f"a ROS 2 parameter cannot hold {text!r}")
    return {"type": kind, VALUE_FIELDS[kind]: plain}


def forward_get_param(ctx: Context, request: Message) -> Forward | None:
    named = served_param(ctx, str(request.get("name", "")), "get_parameters")
    if named is None:
        return None
    node, param = named
    default = str(request.get("default_value", ""))

    def translate(response: Message) -> Message:
        values = response.get("values") or []
        if not values or int(values[0].get("type", NOT_SET)) == NOT_SET:
            if default:
                return {"value": default, "successful": True, "reason": ""}
            return {"value": "null", "successful": False, "reason": f"{node} has no {param}"}
        return {"value": value_json(values[0]), "successful": True, "reason": ""}

    return Forward(f"{node}/get_parameters", {"names": [param]}, translate)


def forward_has_param(ctx: Context, request: Message) -> Forward | None:
    named = served_param(ctx, str(request.get("name", "")), "get_parameters")
    if named is None:
        return None
    node, param = named

    def translate(response: Message) -> Message:
        values = response.get("values") or []
        return {"exists": bool(values) and int(values[0].get("type", NOT_SET)) != NOT_SET}

    return Forward(f"{node}/get_parameters", {"names": [param]}, translate)


def forward_set_param(ctx: Context, request: Message) -> Forward | None:
    named = served_param(ctx, str(request.get("name", "")), "set_parameters")
    if named is None:
        return None
    node, param = named
    value = parameter_value(str(request.get("value", "")))

    def translate(response: Message) -> Message:
        results = response.get("results") or []
        if not results:
            return {"successful": False, "reason": f"{node} answered no result"}
        return {
            "successful": bool(results[0].get("successful")),
            "reason": str(results[0].get("reason", "")),
        }

    parameters = [{"name": param, "value": value}]
    return Forward(f"{node}/set_parameters", {"parameters": parameters}, translate)


def gather_param_names(ctx: Context, request: Message) -> Gather | None:
    """rosapi's `get_param_names` on ROS 2: the bridge's own names, then `node:param` of
    every node whose `list_parameters` is in the graph (None: no such node, the handler
    answers). A node that fails or does not answer in time is left out, as rosbridge does."""
    suffix = "/list_parameters"
    nodes = sorted(
        name[: -len(suffix)]
        for name in ctx.state.graph.services
        if name.endswith(suffix) and len(name) > len(suffix)
    )
    if not nodes:
        return None
    own = sorted(ctx.state.params)

    def combine(answers: list[Message | str]) -> Message:
        names = list(own)
        for node, answer in zip(nodes, answers, strict=True):
            if isinstance(answer, dict):
                listed = (answer.get("result") or {}).get("names") or []
                names += [f"{node}:{name}" for name in listed]
        return {"names": names}

    calls = tuple((f"{node}{suffix}", {"prefixes": [], "depth": 0}) for node in nodes)
    return Gather(calls, combine)


def _plain(value: Any) -> Any:
    """numpy arrays and bytes (canonical array fields) as JSON-ready lists."""
    if isinstance(value, bytes | bytearray | memoryview):
        return list(bytes(value))
    tolist = getattr(value, "tolist", None)
    return tolist() if tolist is not None else value


def kind_of(plain: Any) -> int | None:
    """The ParameterType a JSON value holds (rosapi's rule; None if no ROS 2 type can)."""
    scalar = _scalar_kind(plain)
    if scalar is not None:
        return scalar
    if isinstance(plain, list) and plain:
        kinds = {_scalar_kind(item) for item in plain}
        if kinds == {2, 3}:  # [1, 2.5] is a double array
            kinds = {3}
        if len(kinds) == 1 and (kind := kinds.pop()) is not None:
            return kind + 5  # BOOL 1 -> BOOL_ARRAY 6 ... STRING 4 -> STRING_ARRAY 9
    return None


def _scalar_kind(plain: Any) -> int | None:
    if isinstance(plain, bool):
        return 1
    if isinstance(plain, int):
        return 2
    if isinstance(plain, float):
        return 3
    if isinstance(plain, str):
        return 4
    return None
