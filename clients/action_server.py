"""Serving the actions this client advertises (``advertise_action``).

Each goal runs its handler in its own task: ``async def handler(args, feedback) -> dict``,
where ``await feedback(values)`` sends progress to the caller and the returned dict is the
result. A ``cancel_action_goal`` from the caller cancels the task and answers status CANCELED;
a handler exception answers ``result: false`` (status ABORTED) with the exception text.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from clients.actions import normalize_action_values
from clients.errors import ConnectionClosed
from clients.events import GoalCancel, GoalRequest
from clients.protocol import ClientProtocol
from clients.services import HandlerHost
from clients.wire import Frame
from schemas.registry import TypeRegistry

logger = logging.getLogger(__name__)

STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6
"""action_msgs/GoalStatus values used in ``action_result``."""

Feedback = Callable[[dict[str, Any]], Awaitable[None]]
ActionHandler = Callable[[dict[str, Any], Feedback], Awaitable[dict[str, Any] | None]]


class ActionHost(HandlerHost[ActionHandler]):
    """Runs goal handlers for advertised actions and answers feedback, result and cancel."""

    def __init__(self, registry: TypeRegistry, send: Callable[[Frame], Awaitable[None]]) -> None:
        super().__init__(registry, send)
        self._running: dict[str, asyncio.Task[None]] = {}
        self._cancel_requested: set[str] = set()

    def start(self, goal: GoalRequest) -> None:
        """Run the handler of ``goal`` in a new task (called from the reader)."""
        entry = self._handlers.get(goal.action)
        if entry is None:
            logger.warning("goal for %s, which has no handler here", goal.action)
            return
        task = asyncio.create_task(self._run(goal, *entry), name=f"goal {goal.goal_id}")
        self._running[goal.goal_id] = task
        task.add_done_callback(lambda _t: self._running.pop(goal.goal_id, None))

    def cancel(self, request: GoalCancel) -> None:
        """Cancel a running goal at the caller's request; it then reports CANCELED."""
        task = self._running.get(request.goal_id)
        if task is not None:
            self._cancel_requested.add(request.goal_id)
            task.cancel()

    async def _run(self, goal: GoalRequest, handler: ActionHandler, type: str) -> None:
        async def feedback(values: dict[str, Any]) -> None:
            await self._send(ClientProtocol.action_feedback(goal, values))

        try:
            args = normalize_action_values(self._registry, type, "goal", goal.args)
            values = await handler(args, feedback)
            frame = ClientProtocol.action_result(
                goal, {} if values is None else values, status=STATUS_SUCCEEDED, result=True
            )
        except asyncio.CancelledError:
            if goal.goal_id not in self._cancel_requested:
                raise
            self._cancel_requested.discard(goal.goal_id)
            frame = ClientProtocol.action_result(goal, {}, status=STATUS_CANCELED, result=True)
        except Exception as exc:
            logger.warning("goal %s of %s failed: %r", goal.goal_id, goal.action, exc)
            frame = ClientProtocol.action_result(
                goal, str(exc) or repr(exc), status=STATUS_ABORTED, result=False
            )
        try:
            await self._send(frame)
        except ConnectionClosed as exc:
            logger.warning("could not answer goal %s: %s", goal.goal_id, exc)

    def _running_tasks(self) -> list[asyncio.Task[None]]:
        return list(self._running.values())
