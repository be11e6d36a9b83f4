"""ROS 2 action servers of the domain as actions of the bridge, built on its own ops.

rcl_action puts an action `/fibonacci` on the wire as three services and two topics
(`bridge.dds.naming.action_part`). The service mirror already makes every remote service
callable in the bridge, and the topic mirror makes every remote topic readable, so an
action needs no DDS endpoint of its own: one in-process client (`<bridge node>_actions`)
advertises each remote action and turns the ops the core forwards to it into those calls:

- `send_action_goal` -> `call_service …/_action/send_goal` with a fresh goal UUID; accepted
  -> `call_service …/_action/get_result` (no timeout: it answers when the goal ends), whose
  answer is the `action_result` (status and result); rejected -> a failed `action_result`;
- samples of `…/_action/feedback` (subscribed while the action exists) -> `action_feedback`
  of the goal their UUID names;
- `cancel_action_goal` -> `call_service …/_action/cancel_goal`; the result then says CANCELED.

The other way, an action a websocket client advertises is offered on DDS by a
`DdsActionServer` (`bridge.dds.action_server`); the same client sends its DDS goals to the
provider as `send_action_goal` and hands back `action_feedback` and `action_result`.
"""

from __future__ import annotations

import logging
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from bridge.dds.action_server import ABORTED, DdsActionServer
from bridge.dds.discovery import RemoteAction
from bridge.dds.naming import action_part
from bridge.dds.participant import DdsPlumbing
from bridge.effects import Send
from bridge.host import PluginHost
from bridge.outgoing import ControlMessage, Delivery
from schemas.errors import SchemaError
from schemas.values import JsonObject, Message

logger = logging.getLogger("bridge.dds")

STATUS_ABORTED = 6  # action_msgs/msg/GoalStatus
# get_result answers when the goal ends, however long it runs (the core caps it at a day).
RESULT_TIMEOUT_S = 86_400.0


@dataclass
class _Goal:
    """A goal the core forwarded (its op id) and what it became on the domain."""

    action: str
    op_id: Any
    uuid: bytes
    accepted: bool = False


@dataclass
class _Calls:
    """call_service ids in flight -> (what the call was, goal UUID)."""

    pending: dict[str, tuple[str, bytes]] = field(default_factory=dict)
    count: int = 0

    def new(self, kind: str, goal: bytes) -> str:
        self.count += 1
        call_id = f"dds_action:{self.count}"
        self.pending[call_id] = (kind, goal)
        return call_id


def uuid_bytes(value: Any) -> bytes:
    """A UUID field as 16 bytes, however the core's message carried it (bytes or a list)."""
    raw = value.get("uuid") if isinstance(value, dict) else None
    if isinstance(raw, bytes | bytearray | memoryview):
        return bytes(raw)
    if isinstance(raw, list | tuple):
        return bytes(int(b) & 0xFF for b in raw)
    tolist = getattr(raw, "tolist", None)  # a numpy array
    return bytes(tolist()) if tolist is not None else b""


class ActionMirror:
    """Keeps the bridge's stand-ins of the domain's action servers and runs their goals."""

    def __init__(
        self,
        host: PluginHost,
        node: str,
        own_clients: set[int],
        dds: DdsPlumbing,
        to_loop: Callable[..., object],
    ) -> None:
        self._host = host
        self._dds, self._to_loop = dds, to_loop
        self.served: dict[str, DdsActionServer] = {}
        self._dds_goals: dict[str, tuple[DdsActionServer, bytes]] = {}  # op id -> goal
        self._dds_goal_count = 0
        self._refused: set[str] = set()
        self.node = f"{node}_actions"
        self.client = host.connect_internal(self.node, self._receives, peer="dds")
        own_clients.add(self.client)  # the mirror's own: never a websocket client's node
        self.remote: dict[str, RemoteAction] = {}
        self._goals: dict[bytes, _Goal] = {}
        self._calls = _Calls()

    def sync(self, remote: dict[str, RemoteAction], services: set[str], local: set[str]) -> None:
        """Advertise each remote action whose services the bridge can call, unless a
        websocket client provides one of that name (never replaced); drop the rest."""
        wanted = {
            name: action
            for name, action in remote.items()
            if name not in local
            and all(action_part(name, p) in services for p in ("send_goal", "get_result"))
        }
        for name in [n for n, a in self.remote.items() if wanted.get(n) != a]:
            self._withdraw(name)
        for name, action in wanted.items():
            if name not in self.remote:
                self._adopt(action)

    def _adopt(self, action: RemoteAction) -> None:
        self.remote[action.name] = action
        self._send({"op": "advertise_action", "action": action.name, "type": action.type_name})
        feedback = action_part(action.name, "feedback")
        self._send(
            {
                "op": "subscribe",
                "topic": feedback,
                "type": f"{action.type_name}_FeedbackMessage",
                "id": f"dds_action:{feedback}",
            }
        )

    def _withdraw(self, name: str) -> None:
        """The server left: unadvertising fails the goals still running."""
        del self.remote[name]
        self._send({"op": "unadvertise_action", "action": name})
        feedback = action_part(name, "feedback")
        self._send({"op": "unsubscribe", "topic": feedback, "id": f"dds_action:{feedback}"})
        for key in [k for k, g in self._goals.items() if g.action == name]:
            del self._goals[key]

    def close(self) -> None:
        self.sync_local({})
        self._host.disconnect_internal(self.client)

    # -- websocket clients' actions offered on DDS -------------------------------------------

    def sync_local(self, local: dict[str, str]) -> bool:
        """Offer each action websocket clients provide (name -> type) on DDS; True if the
        DDS endpoints changed."""
        changed = False
        for name in [n for n, server in self.served.items() if local.get(n) != server.type_name]:
            self.served.pop(name).close()
            changed = True
        for name, type_name in local.items():
            if name in self.served or name in self._refused:
                continue
            try:
                self.served[name] = DdsActionServer(
                    self._dds, name, type_name, self, self._to_loop, self._host.now_ns
                )
            except (SchemaError, ValueError) as exc:
                self._refused.add(name)
                logger.warning("DDS: action %s (%s) is not offered: %s", name, type_name, exc)
                continue
            changed = True
        return changed

    def submit(self, server: DdsActionServer, goal_id: bytes, goal: Message) -> None:
        """A DDS client's goal, sent to the websocket provider."""
        self._dds_goal_count += 1
        op_id = f"dds_goal:{self._dds_goal_count}"
        self._dds_goals[op_id] = (server, goal_id)
        self._send(
            {
                "op": "send_action_goal",
                "action": server.name,
                "action_type": server.type_name,
                "args": goal,
                "id": op_id,
                "feedback": True,
            }
        )

    def cancel(self, server: DdsActionServer, goal_id: bytes) -> None:
        for op_id, (owner, goal) in self._dds_goals.items():
            if owner is server and goal == goal_id:
                self._send({"op": "cancel_action_goal", "id": op_id, "action": server.name})

    def _provider_answered(self, payload: dict[str, Any]) -> bool:
        """`action_feedback`/`action_result` for a DDS client's goal; False if not ours."""
        op_id = str(payload.get("id"))
        goal = self._dds_goals.get(op_id)
        if goal is None:
            return False
        server, goal_id = goal
        values = payload.get("values")
        if payload.get("op") == "action_feedback":
            server.feedback(goal_id, values if isinstance(values, dict) else {})
            return True
        del self._dds_goals[op_id]
        if payload.get("result") is True and isinstance(values, dict):
            status = payload.get("status")
            server.finish(goal_id, status if isinstance(status, int) else ABORTED, values)
        else:
            logger.warning("DDS: goal of %s from DDS failed: %s", server.name, values)
            server.finish(goal_id, ABORTED, None)
        return True

    def guids(self) -> tuple[list[bytes], list[bytes]]:
        """(reader GUIDs, writer GUIDs) of every offered action's endpoints."""
        pairs = [server.guids() for server in self.served.values()]
        return [g for r, _ in pairs for g in r], [g for _, w in pairs for g in w]

    def _send(self, op: JsonObject) -> None:
        self._host.send_op(self.client, op)

    # -- what the core sends the stand-in ----------------------------------------------------

    def _receives(self, send: Send) -> None:
        item = send.item
        if isinstance(item, Delivery):
            self._feedback(item.message.msg)
            return
        payload = item.payload if isinstance(item, ControlMessage) else {}
        if payload.get("op") in ("action_feedback", "action_result"):
            self._provider_answered(payload)
            return
        handler = {
            "send_action_goal": self._send_goal,
            "cancel_action_goal": self._cancel,
            "service_response": self._answered,
        }.get(str(payload.get("op")))
        if handler is not None:
            handler(payload)

    def _send_goal(self, payload: dict[str, Any]) -> None:
        name = str(payload.get("action"))
        goal = _Goal(name, payload.get("id"), uuid.uuid4().bytes)
        self._goals[goal.uuid] = goal
        self._call(
            name,
            "send_goal",
            goal.uuid,
            {"goal_id": {"uuid": list(goal.uuid)}, "goal": payload.get("args") or {}},
        )

    def _cancel(self, payload: dict[str, Any]) -> None:
        goal = next((g for g in self._goals.values() if g.op_id == payload.get("id")), None)
        if goal is None:
            return
        info = {"goal_id": {"uuid": list(goal.uuid)}, "stamp": {"sec": 0, "nanosec": 0}}
        self._call(goal.action, "cancel_goal", goal.uuid, {"goal_info": info})

    def _call(
        self, action: str, part: str, goal: bytes, args: JsonObject, timeout_s: float = 0.0
    ) -> None:
        op: JsonObject = {
            "op": "call_service",
            "service": action_part(action, part),
            "args": args,
            "id": self._calls.new(part, goal),
        }
        if timeout_s:
            op["timeout"] = timeout_s
        self._send(op)

    def _answered(self, payload: dict[str, Any]) -> None:
        kind, goal_uuid = self._calls.pending.pop(str(payload.get("id")), ("", b""))
        goal = self._goals.get(goal_uuid)
        if goal is None:
            return
        values = payload.get("values")
        if payload.get("result") is not True or not isinstance(values, dict):
            if kind == "cancel_goal":
                logger.warning("DDS: cancel of a goal of %s failed: %s", goal.action, values)
                return
            self._finish(goal, f"{goal.action} {kind} failed: {values}", STATUS_ABORTED, False)
        elif kind == "send_goal" and values.get("accepted"):
            goal.accepted = True
            self._call(
                goal.action,
                "get_result",
                goal.uuid,
                {"goal_id": {"uuid": list(goal.uuid)}},
                RESULT_TIMEOUT_S,
            )
        elif kind == "send_goal":
            self._finish(goal, f"the goal was rejected by {goal.action}", STATUS_ABORTED, False)
        elif kind == "get_result":
            status = values.get("status")
            self._finish(goal, values.get("result", {}), status, True)

    def _finish(self, goal: _Goal, values: Any, status: Any, ok: bool) -> None:
        self._goals.pop(goal.uuid, None)
        self._send(
            {
                "op": "action_result",
                "action": goal.action,
                "id": goal.op_id,
                "values": values,
                "status": int(status) if isinstance(status, int) else STATUS_ABORTED,
                "result": ok,
            }
        )

    def _feedback(self, msg: dict[str, Any]) -> None:
        goal = self._goals.get(uuid_bytes(msg.get("goal_id")))
        if goal is None:  # (feedback may come before the send_goal reply: no accepted check)
            return
        self._send(
            {
                "op": "action_feedback",
                "action": goal.action,
                "id": goal.op_id,
                "values": msg.get("feedback", {}),
            }
        )
