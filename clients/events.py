"""What the sans-I/O protocol reports after reading a frame, and what a subscriber receives.

Events are plain frozen records; the protocol decides *where* an incoming op goes (which
subscriptions, which pending call, which service handler) and the asyncio client only carries
the event to its destination.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Received:
    """One message delivered to a subscription.

    topic : the topic name exactly as subscribed.
    msg : the message; canonical form (docs/messages.md) when the subscription named a type.
    recv_ns : wall clock (``time.time_ns()``) when the frame carrying it arrived, for latency
        tracing against ``header.stamp`` on the same host.
    wire_bytes : size of the websocket payload(s) that carried it (all fragments together).
    """

    topic: str
    msg: dict[str, Any]
    recv_ns: int
    wire_bytes: int


@dataclass(frozen=True, slots=True)
class TopicMessage:
    """A ``publish`` from the bridge, routed to the subscription ids that want it."""

    sub_ids: tuple[str, ...]
    received: Received


@dataclass(frozen=True, slots=True)
class ServiceReply:
    """A ``service_response`` matching a pending call of ours."""

    call_id: str
    service: str
    result: bool
    values: Any


@dataclass(frozen=True, slots=True)
class ServiceRequest:
    """A ``call_service`` from the bridge for a service this client advertised."""

    request_id: Any
    service: str
    args: Any


@dataclass(frozen=True, slots=True)
class ActionFeedback:
    """An ``action_feedback`` for a goal this client sent."""

    goal_id: str
    action: str
    values: Any


@dataclass(frozen=True, slots=True)
class ActionOutcome:
    """An ``action_result`` for a goal this client sent (``status``: action_msgs/GoalStatus)."""

    goal_id: str
    action: str
    status: int
    result: bool
    values: Any


@dataclass(frozen=True, slots=True)
class GoalRequest:
    """A ``send_action_goal`` from the bridge for an action this client advertised."""

    goal_id: str
    action: str
    action_type: str | None
    args: Any


@dataclass(frozen=True, slots=True)
class GoalCancel:
    """A ``cancel_action_goal`` from the bridge for a goal this client is serving."""

    goal_id: str
    action: str


@dataclass(frozen=True, slots=True)
class Ignored:
    """An op nobody here waits for (unknown op, late reply, status); ``reason`` says why."""

    op: str
    reason: str


Event = (
    TopicMessage
    | ServiceReply
    | ServiceRequest
    | ActionFeedback
    | ActionOutcome
    | GoalRequest
    | GoalCancel
    | Ignored
)
