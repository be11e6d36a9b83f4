"""rosapi parameter services: the bridge's own, kept in the bridge, and other nodes'
(`/node:param`, asked of that node through `bridge.rosapi.node_params`).

Values are JSON text both ways, as rosapi clients `json.loads` / `JSON.parse` them.
"""

from __future__ import annotations

from dataclasses import replace

from bridge.context import Context
from bridge.errors import RosapiError
from bridge.rosapi.common import table, text_arg
from bridge.rosapi.node_params import (
    forward_get_param,
    forward_has_param,
    forward_set_param,
    gather_param_names,
)
from schemas import codec_json
from schemas.errors import DecodeError
from schemas.safety import echo
from schemas.values import Message

PREFIX = "/rosapi"
# Parameters are kept in the bridge for every client to read: bound what one client can store.
MAX_PARAMS = 1000
MAX_PARAM_NAME_CHARS = 256
MAX_PARAM_VALUE_CHARS = 64 * 1024


def param_name(request: Message) -> str:
    name = text_arg(request, "name")
    if not name:
        raise RosapiError("parameter name must not be empty")
    if len(name) > MAX_PARAM_NAME_CHARS or not name.isprintable():
        raise RosapiError(
            f"parameter name {echo(name, 60)} must be at most "
            f"{MAX_PARAM_NAME_CHARS} printable characters"
        )
    return name


def get_param(ctx: Context, request: Message) -> Message:
    name = param_name(request)
    if name in ctx.state.params:
        return {"value": ctx.state.params[name], "successful": True, "reason": ""}
    default = text_arg(request, "default_value")
    if default:
        return {"value": default, "successful": True, "reason": ""}
    return {"value": "null", "successful": False, "reason": f"Parameter {name} is not set"}


def set_param(ctx: Context, request: Message) -> Message:
    name = param_name(request)
    value = text_arg(request, "value")
    if len(value) > MAX_PARAM_VALUE_CHARS:
        raise RosapiError(f"value of {name} is longer than {MAX_PARAM_VALUE_CHARS} characters")
    if name not in ctx.state.params and len(ctx.state.params) >= MAX_PARAMS:
        raise RosapiError(f"the bridge keeps at most {MAX_PARAMS} parameters")
    try:
        codec_json.loads(value.encode())
    except DecodeError as exc:
        raise RosapiError(f"value of {name} is not JSON text: {exc}") from exc
    ctx.state.params[name] = value
    return {"successful": True, "reason": ""}


def has_param(ctx: Context, request: Message) -> Message:
    return {"exists": param_name(request) in ctx.state.params}


def delete_param(ctx: Context, request: Message) -> Message:
    name = param_name(request)
    if ctx.state.params.pop(name, None) is None:
        return {"successful": False, "reason": f"Parameter {name} is not set"}
    return {"successful": True, "reason": ""}


def get_param_names(ctx: Context, request: Message) -> Message:
    return {"names": sorted(ctx.state.params)}


SERVICES = table(
    PREFIX,
    {
        "get_param": ("GetParam", get_param),
        "set_param": ("SetParam", set_param),
        "has_param": ("HasParam", has_param),
        "delete_param": ("DeleteParam", delete_param),
        "get_param_names": ("GetParamNames", get_param_names),
    },
)
# `node_name:param_name` is another node's parameter: asked of that node (rosbridge on ROS 2).
for _name, _forward in (
    ("get_param", forward_get_param),
    ("set_param", forward_set_param),
    ("has_param", forward_has_param),
    ("get_param_names", gather_param_names),
):
    SERVICES[f"{PREFIX}/{_name}"] = replace(SERVICES[f"{PREFIX}/{_name}"], forward=_forward)
