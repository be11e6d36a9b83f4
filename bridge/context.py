"""Shared core state and the per-call context handlers write their effects into."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bridge.config import BridgeConfig
from bridge.effects import Close, DeadlineKey, Effect, Schedule, Send
from bridge.graph import Graph
from bridge.outgoing import ControlMessage, Delivery, TopicMessage
from bridge.roles import Policy
from bridge.session import ClientSession, StatusLevel
from bridge.sinks import LocalFanout, MessageSink
from bridge.subscription import Release, Subscription
from schemas.ops import OpBase, Status, to_wire
from schemas.registry import TypeRegistry
from schemas.safety import echo, safe_text
from schemas.values import Message, OpId

if TYPE_CHECKING:
    from bridge.inbound import InboundFrame
    from bridge.rosapi.common import RosapiService

logger = logging.getLogger("bridge.core")


@dataclass
class PendingCall:
    """A call forwarded to a provider, waiting for its `service_response`."""

    service: str
    provider: int
    caller: int
    caller_id: OpId
    caller_service: str
    timeout_s: float
    # A rosapi call answered by another service: its response -> the rosapi response.
    translate: Callable[[Message], Message] | None = None
    # One of the calls a rosapi call gathers answers from (`bridge.rosapi.common.Gather`).
    gathering: Gathering | None = None
    slot: int = 0


@dataclass
class Gathering:
    """The answers a rosapi call waits for (None: not yet), combined once all are in."""

    combine: Callable[[list[Message | str]], Message]
    answers: list[Message | str | None]


@dataclass
class PendingGoal:
    """A goal forwarded to an action provider, waiting for its `action_result`."""

    action: str
    provider: int
    caller: int
    caller_id: OpId
    caller_action: str
    feedback: bool


class BridgeState:
    """Everything the core knows; owned by one `BridgeCore`, mutated only through handlers."""

    def __init__(self, config: BridgeConfig, registry: TypeRegistry) -> None:
        self.config = config
        self.registry = registry
        self.graph = Graph()
        self.sessions: dict[int, ClientSession] = {}
        self.topic_subscriptions: dict[str, dict[int, Subscription]] = {}
        self.pending_calls: dict[str, PendingCall] = {}
        self.pending_goals: dict[str, PendingGoal] = {}
        self.params: dict[str, str] = {}
        self.sinks: list[MessageSink] = [LocalFanout()]
        # Nodes of other graphs by source (a DDS domain's ROS 2 nodes), for rosapi's listings.
        self.external_graphs: dict[str, frozenset[str]] = {}
        # Services the bridge answers itself, name -> RosapiService (set by the core).
        self.rosapi: dict[str, RosapiService] = {}
        self.clients_ever = 0
        # Who may do what (--roles) and the audit trail (bridge.roles); inactive without both.
        self.policy = Policy(config.roles)

    @property
    def external_nodes(self) -> frozenset[str]:
        """The nodes of every other graph (`BridgeCore.set_external_nodes`)."""
        return frozenset().union(*self.external_graphs.values())

    def session_of_node(self, node: str) -> ClientSession | None:
        return next((s for s in self.sessions.values() if s.node == node), None)


class Context:
    """One core call: the state, the time it happens at, the client's frame it handles (None
    for a call that handles none: a deadline, an in-process source) and the effects produced.
    """

    def __init__(self, state: BridgeState, now_ns: int, frame: InboundFrame | None = None) -> None:
        self.state = state
        self.now_ns = now_ns
        self.frame = frame
        self.effects: list[Effect] = []
        # Texts of completed fragment lists, fed back to the core as inbound messages.
        self.reassembled: list[str] = []

    def send(self, client_id: int, op: OpBase) -> None:
        """Queue an op for a client as JSON; it will never be dropped from the send queue.

        `op` is a `schemas.ops` model, the one definition of the op both ways: the bridge
        answers with the types it reads (`to_wire`: rosbridge's key order, no null id).
        """
        session = self.state.sessions.get(client_id)
        if session is not None:
            self.effects.append(
                Send(client_id, ControlMessage(to_wire(op)), None, session.fragment_size_for())
            )

    def release(self, session: ClientSession, subscription: Subscription, release: Release) -> None:
        """Turn a subscription's release into deliveries and a wake-up deadline."""
        for message in release.messages:
            self.deliver(session, subscription, message)
        if release.wake_at_ns is not None:
            self.schedule(("release", session.client_id, subscription.topic), release.wake_at_ns)

    def deliver(
        self, session: ClientSession, subscription: Subscription, message: TopicMessage
    ) -> None:
        """Send one message of `subscription` to its client, as the subscription asked."""
        settings = subscription.settings
        self.effects.append(
            Send(
                session.client_id,
                Delivery(message, subscription.spelling, settings.compression, settings.reduce),
                subscription.topic,
                session.fragment_size_for(subscription),
                settings.queue_length,
            )
        )

    def publish(self, message: TopicMessage, origin_node: str) -> None:
        """Hand a message to every sink (local subscribers first)."""
        for sink in self.state.sinks:
            sink.accept(self, message, origin_node)

    def note_problem(self, session: ClientSession) -> bool:
        """Count a problem of `session`; True if it may be logged in full (see ProblemLog)."""
        summary = session.problems.expired_summary(self.now_ns, session.node)
        if summary is not None:
            logger.warning("%s", summary)
        full, deadline = session.problems.note(self.now_ns)
        if deadline is not None:
            self.schedule(("problems", session.client_id), deadline)
        return full

    def schedule(self, key: DeadlineKey, at_ns: int) -> None:
        self.effects.append(Schedule(key, at_ns))

    def close(self, client_id: int, code: int, reason: str) -> None:
        self.effects.append(Close(client_id, code, reason))

    def problem(
        self,
        session: ClientSession,
        op: str,
        op_id: OpId,
        text: str,
        level: StatusLevel = StatusLevel.ERROR,
        exc_info: BaseException | None = None,
    ) -> None:
        """Log one short line naming client, op, id and problem (rate-limited per client,
        `bridge.problems`); tell the client if it opted in with `set_level`."""
        text = safe_text(text)
        if self.note_problem(session):
            log_level = {StatusLevel.INFO: logging.INFO, StatusLevel.WARNING: logging.WARNING}.get(
                level, logging.ERROR
            )
            shown_id = safe_text(op_id, 80) if isinstance(op_id, str) else echo(op_id, 80)
            logger.log(
                log_level,
                "[%s] op=%s id=%s: %s",
                session.node,
                safe_text(op, 60),
                shown_id,
                text,
                exc_info=exc_info,
            )
        if level >= session.status_level and session.status_level != StatusLevel.NONE:
            self.send(session.client_id, Status(level=level.name.lower(), msg=text, id=op_id))


def log_problem_summary(ctx: Context, client_id: int) -> None:
    """A client's problem window ended: one line for everything not logged in it."""
    session = ctx.state.sessions.get(client_id)
    if session is not None:
        summary = session.problems.expired_summary(ctx.now_ns, session.node)
        if summary is not None:
            logger.warning("%s", summary)
