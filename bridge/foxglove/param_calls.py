"""A Foxglove client's requests for ROS 2 nodes' parameters, as the core's service calls.

`getParameters` and `setParameters` naming `/node.param` (`bridge.foxglove.node_parameters`)
become `call_service` ops of the client to `<node>/get_parameters`, `set_parameters` and
`list_parameters`, the calls rosapi forwards too: the core routes them wherever the service
lives (a DDS node through the mirror) and answers each exactly once, with the node's answer
or a failure (unknown service, the bridge's call timeout, `call_timeout_s`). Nodes are asked
concurrently; a failed node costs its parameters, reported in `problems`, never the others.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from bridge.foxglove.node_parameters import (
    GET,
    LIST,
    SERVICE_TYPES,
    SET,
    by_node,
    full_name,
    set_failures,
    to_foxglove,
)
from bridge.host import PluginHost
from schemas.values import JsonObject, Message

OP_PREFIX = "fgn:"  # ids of these calls among the client's ops (the session's are fg*:)


@dataclass
class Outcome:
    """Foxglove parameters read (in request order) and what went wrong, one line each."""

    parameters: list[dict[str, Any]] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


class NodeParameterCalls:
    """One Foxglove client's parameter calls to other nodes, awaited by op id."""

    def __init__(self, host: PluginHost, client_id: int) -> None:
        self._host = host
        self._client_id = client_id
        self._waiting: dict[str, asyncio.Future[Message | str]] = {}
        self._count = 0

    async def call(self, node: str, service: str, args: JsonObject) -> Message | str:
        """The node's response values, or the failure text the core answered with."""
        self._count += 1
        op_id = f"{OP_PREFIX}{self._count}"
        future: asyncio.Future[Message | str] = asyncio.get_running_loop().create_future()
        self._waiting[op_id] = future
        op = {"op": "call_service", "id": op_id, "service": f"{node}/{service}"}
        self._host.send_op(self._client_id, {**op, "type": SERVICE_TYPES[service], "args": args})
        return await future

    def answered(self, payload: Mapping[str, Any]) -> bool:
        """Take a `service_response` meant for one of these calls (True if it was one)."""
        op_id = payload.get("id")
        if payload.get("op") != "service_response" or not isinstance(op_id, str):
            return False
        future = self._waiting.pop(op_id, None)
        if future is None:
            return op_id.startswith(OP_PREFIX)
        values = payload.get("values")
        ok = payload.get("result") is True and isinstance(values, dict)
        if not future.done():
            future.set_result(values if ok and isinstance(values, dict) else str(values))
        return True

    def close(self) -> None:
        for future in self._waiting.values():
            future.cancel()
        self._waiting.clear()

    async def get(self, wanted: list[tuple[str, str]]) -> Outcome:
        """The values of (node, parameter) pairs, asked of each node once. rclpy answers no
        values at all when one name is not declared: such a node is asked name by name, so
        only the undeclared are left out (as foxglove_bridge leaves out what a node lacks)."""
        grouped = by_node(wanted)
        answers = await asyncio.gather(
            *(self._get_node(node, params) for node, params in grouped.items())
        )
        outcome = Outcome()
        for (node, params), answer in zip(grouped.items(), answers, strict=True):
            if isinstance(answer, str):
                names = ", ".join(full_name(node, p) for p in params)
                outcome.problems.append(f"getting {names} failed: {answer}")
                continue
            for param, value in zip(params, answer, strict=True):
                parameter = to_foxglove(node, param, value) if value is not None else None
                if parameter is not None:
                    outcome.parameters.append(parameter)
        return outcome

    async def _get_node(self, node: str, params: list[str]) -> list[Message | None] | str:
        """One node's ParameterValues for `params` (None where it has none), or why not."""
        answer = await self.call(node, GET, {"names": params})
        if isinstance(answer, str):
            return answer
        values = list(answer.get("values") or [])
        if len(values) == len(params):
            return values
        if len(params) == 1:
            return [None]
        singles = await asyncio.gather(*(self._get_node(node, [p]) for p in params))
        failed = [one for one in singles if isinstance(one, str)]
        if len(failed) == len(singles):
            return failed[0]  # the node stopped answering: say so once
        return [one[0] if isinstance(one, list) else None for one in singles]

    async def get_all(self, nodes: list[str]) -> Outcome:
        """Every parameter of `nodes` (list_parameters, then get_parameters)."""
        lists = await asyncio.gather(
            *(self.call(node, LIST, {"prefixes": [], "depth": 0}) for node in nodes)
        )
        outcome = Outcome()
        wanted = []
        for node, answer in zip(nodes, lists, strict=True):
            if isinstance(answer, str):
                outcome.problems.append(f"listing {node}'s parameters failed: {answer}")
                continue
            names = (answer.get("result") or {}).get("names") or []
            wanted += [(node, str(name)) for name in names]
        values = await self.get(wanted) if wanted else Outcome()
        outcome.parameters += values.parameters
        outcome.problems += values.problems
        return outcome

    async def set(self, values: list[tuple[str, str, Message]]) -> tuple[list[str], list[str]]:
        """Set (node, parameter, ParameterValue) triples: the full names the nodes took, and
        what went wrong, one line each."""
        grouped = by_node((node, param) for node, param, _ in values)
        by_name = {(node, param): value for node, param, value in values}
        answers = await asyncio.gather(
            *(
                self.call(
                    node,
                    SET,
                    {"parameters": [{"name": p, "value": by_name[node, p]} for p in params]},
                )
                for node, params in grouped.items()
            )
        )
        taken, problems = [], []
        for (node, params), answer in zip(grouped.items(), answers, strict=True):
            failed = set_failures(node, params, answer)
            problems += [problem for _, problem in failed]
            refused = {param for param, _ in failed}
            taken += [full_name(node, p) for p in params if p not in refused]
        return taken, problems
