"""A websocket client's action offered on DDS, as rcl_action's server puts it on the wire.

`/fibonacci` of `pkg/action/T` gets three service servers (`…/_action/send_goal`,
`…/get_result`, `…/cancel_goal`, with rmw_cyclonedds's request header) and two writers,
`rt/fibonacci/_action/feedback` (`T_FeedbackMessage`) and `…/status` (`GoalStatusArray`,
transient local, keep-last 1, as rcl_action's status QoS). A DDS goal is accepted at once and
handed to the bridge through `Goals.submit` (the action mirror sends it as a
`send_action_goal`); what the provider answers comes back through `feedback` and `finish`.
A `get_result` asked before the goal ends is answered when it ends. Requests arrive on the
event loop (`to_loop`); replies and samples leave through the outbox.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from bridge.dds.naming import action_part, topic_to_dds
from bridge.dds.participant import DdsPlumbing, RawWriter
from bridge.dds.qos import DEFAULT, QosProfile
from bridge.dds.request_header import RequestId
from bridge.dds.service_endpoints import ServiceServer
from schemas.codec_cdr import to_cdr
from schemas.values import Message

logger = logging.getLogger("bridge.dds")

STATUS_TYPE = "action_msgs/msg/GoalStatusArray"
CANCEL_TYPE = "action_msgs/srv/CancelGoal"
# rcl_action's status topic QoS: the last status array waits for late action clients.
STATUS_QOS = QosProfile(reliable=True, transient_local=True, depth=1)
# action_msgs/msg/GoalStatus and CancelGoal return codes.
EXECUTING, CANCELING, ABORTED = 2, 3, 6
CANCEL_OK, CANCEL_UNKNOWN_GOAL = 0, 2
KEEP_FINISHED = 100  # finished goals whose result a late get_result may still ask for
ZERO_UUID = bytes(16)


class Goals(Protocol):
    """Where DDS goals go: the action mirror's in-process client."""

    def submit(self, server: DdsActionServer, goal_id: bytes, goal: Message) -> None: ...

    def cancel(self, server: DdsActionServer, goal_id: bytes) -> None: ...


@dataclass
class _Goal:
    stamp: Message
    status: int = EXECUTING
    result: Message | None = None
    waiting: list[RequestId] = field(default_factory=list)


def uuid_of(goal_id: Any) -> bytes:
    raw = goal_id.get("uuid") if isinstance(goal_id, dict) else None
    return bytes(raw) if raw is not None else b""


class DdsActionServer:
    """The DDS endpoints of one local action and the goals DDS clients sent it."""

    def __init__(
        self,
        dds: DdsPlumbing,
        name: str,
        type_name: str,
        goals: Goals,
        to_loop: Callable[..., object],
        now_ns: Callable[[], int],
    ) -> None:
        spec = dds.registry.action(type_name)
        self.name, self.type_name = name, spec.name
        self._dds, self._goals_out, self._now_ns = dds, goals, now_ns
        self.goals: dict[bytes, _Goal] = {}

        def on_loop(handler: Callable[..., None]) -> Callable[..., object]:
            return lambda *args: to_loop(handler, *args)

        self.servers = [
            ServiceServer(
                dds, action_part(name, "send_goal"), f"{spec.name}_SendGoal", on_loop(self._goal)
            ),
            ServiceServer(
                dds,
                action_part(name, "get_result"),
                f"{spec.name}_GetResult",
                on_loop(self._result_asked),
            ),
            ServiceServer(
                dds, action_part(name, "cancel_goal"), CANCEL_TYPE, on_loop(self._cancel)
            ),
        ]
        self._feedback_type = f"{spec.name}_FeedbackMessage"
        self.feedback_writer = self._writer("feedback", self._feedback_type, DEFAULT)
        self.status_writer = self._writer("status", STATUS_TYPE, STATUS_QOS)

    def _writer(self, part: str, type_name: str, profile: QosProfile) -> RawWriter:
        participant, registry = self._dds.participant, self._dds.registry
        return participant.writer(
            topic_to_dds(action_part(self.name, part)),
            participant.types.message(registry.message(type_name)),
            profile,
            self._dds.type_hash(type_name),
        )

    # -- DDS clients' requests (on the loop) -------------------------------------------------

    def _goal(self, _service: str, request: RequestId, msg: Message) -> None:
        goal_id = uuid_of(msg.get("goal_id"))
        stamp = _stamp(self._now_ns())
        self.goals[goal_id] = _Goal(stamp)
        self._forget_old()
        self.servers[0].send(request, {"accepted": True, "stamp": stamp})
        self._goals_out.submit(self, goal_id, msg.get("goal") or {})
        self._publish_status()

    def _result_asked(self, _service: str, request: RequestId, msg: Message) -> None:
        goal = self.goals.get(uuid_of(msg.get("goal_id")))
        if goal is None:  # rcl_action answers an unknown goal with status UNKNOWN (0)
            self.servers[1].send(request, {"status": 0, "result": {}})
        elif goal.result is None:
            goal.waiting.append(request)
        else:
            self.servers[1].send(request, {"status": goal.status, "result": goal.result})

    def _cancel(self, _service: str, request: RequestId, msg: Message) -> None:
        info = msg.get("goal_info") or {}
        asked = uuid_of(info.get("goal_id"))
        canceling = [
            goal_id
            for goal_id, goal in self.goals.items()
            if goal.result is None and asked in (goal_id, ZERO_UUID)
        ]
        for goal_id in canceling:
            self.goals[goal_id].status = CANCELING
            self._goals_out.cancel(self, goal_id)
        infos = [
            {"goal_id": {"uuid": goal_id}, "stamp": self.goals[goal_id].stamp}
            for goal_id in canceling
        ]
        code = CANCEL_OK if canceling else CANCEL_UNKNOWN_GOAL
        self.servers[2].send(request, {"return_code": code, "goals_canceling": infos})
        self._publish_status()

    # -- what the websocket provider answered (on the loop) ----------------------------------

    def feedback(self, goal_id: bytes, values: Message) -> None:
        msg = {"goal_id": {"uuid": goal_id}, "feedback": values}
        self._write(self.feedback_writer, self._feedback_type, msg, "feedback")

    def finish(self, goal_id: bytes, status: int, result: Message | None) -> None:
        goal = self.goals.get(goal_id)
        if goal is None:
            return
        goal.status = status
        goal.result = result if result is not None else {}
        for request in goal.waiting:
            self.servers[1].send(request, {"status": goal.status, "result": goal.result})
        goal.waiting.clear()
        self._publish_status()

    def _publish_status(self) -> None:
        statuses = [
            {
                "goal_info": {"goal_id": {"uuid": goal_id}, "stamp": goal.stamp},
                "status": goal.status,
            }
            for goal_id, goal in self.goals.items()
        ]
        self._write(self.status_writer, STATUS_TYPE, {"status_list": statuses}, "status")

    def _write(self, writer: RawWriter, type_name: str, msg: Message, part: str) -> None:
        cdr = to_cdr(self._dds.registry, type_name, msg)

        def write() -> None:
            if writer.write(cdr) < 0:
                logger.warning("DDS: %s of action %s not written", part, self.name)

        self._dds.outbox.put(("action", self.name, part), write)

    def _forget_old(self) -> None:
        finished = [g for g, goal in self.goals.items() if goal.result is not None]
        for goal_id in finished[: max(0, len(finished) - KEEP_FINISHED)]:
            del self.goals[goal_id]

    def guids(self) -> tuple[list[bytes], list[bytes]]:
        """(reader GUIDs, writer GUIDs) of every endpoint, for `ros_discovery_info`."""
        pairs = [server.guids() for server in self.servers]
        writers = [w for _, w in pairs] + [self.feedback_writer.guid, self.status_writer.guid]
        return [r for r, _ in pairs], writers

    def close(self) -> None:
        for server in self.servers:
            server.close()
        self._dds.participant.delete(self.feedback_writer.entity)
        self._dds.participant.delete(self.status_writer.entity)


def _stamp(now_ns: int) -> Message:
    return {"sec": now_ns // 1_000_000_000, "nanosec": now_ns % 1_000_000_000}
