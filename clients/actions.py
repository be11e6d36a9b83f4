"""Handle of one ROS 2 action goal sent through the bridge (``send_action_goal``)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable
from typing import Any, Literal

from clients.errors import ActionError
from clients.events import ActionFeedback, ActionOutcome
from schemas.errors import SchemaError
from schemas.message import normalize
from schemas.registry import TypeRegistry

logger = logging.getLogger(__name__)

GOAL_SUCCEEDED = 4
"""action_msgs/GoalStatus STATUS_SUCCEEDED; 5 is CANCELED and 6 ABORTED."""

FEEDBACK_KEEP = 32
"""Feedback messages kept for a slow reader (oldest dropped): feedback is progress, not data."""


def normalize_action_values(
    registry: TypeRegistry,
    type: str | None,
    part: Literal["goal", "result", "feedback"],
    values: Any,
) -> Any:
    """Canonical form of goal/result/feedback values when ``type`` is a known action.

    Values of unknown action types, or that are not objects (a failure's error text), are
    returned as they are. Raises :class:`schemas.errors.SchemaError` for invalid values.
    """
    if type is None or not isinstance(values, dict) or not registry.has_action(type):
        return values
    return normalize(getattr(registry.action(type), part), values, now_ns=time.time_ns())


class ActionGoal:
    """A goal in flight: iterate feedback, await the result, or cancel it.

    ``await goal.result()`` returns the result ``values`` when the goal finishes with status
    SUCCEEDED; otherwise (failure, abort, cancel) it raises :class:`ActionError` carrying the
    status. :class:`clients.errors.ConnectionClosed` is raised if the connection drops first.
    ``async for values in goal.feedback()`` yields feedback until the goal ends. Feedback and
    result come in canonical form when ``registry`` knows ``action_type``.
    """

    def __init__(
        self,
        goal_id: str,
        action: str,
        action_type: str,
        registry: TypeRegistry,
        cancel: Callable[[ActionGoal], Awaitable[None]],
    ) -> None:
        self.id = goal_id
        self.action = action
        self.action_type = action_type
        self._registry = registry
        self._cancel = cancel
        self._outcome: asyncio.Future[ActionOutcome] = asyncio.get_running_loop().create_future()
        self._feedback: deque[Any] = deque(maxlen=FEEDBACK_KEEP)
        self._wakeup = asyncio.Event()

    def on_feedback(self, event: ActionFeedback) -> None:
        """Queue one feedback (client reader only)."""
        self._feedback.append(self._normalized("feedback", event.values))
        self._wakeup.set()

    def on_outcome(self, event: ActionOutcome) -> None:
        """Record the final result (client reader only)."""
        if not self._outcome.done():
            self._outcome.set_result(event)
        self._wakeup.set()

    def fail(self, exc: BaseException) -> None:
        """End the goal with an exception (connection lost, client closed)."""
        if not self._outcome.done():
            self._outcome.set_exception(exc)
            self._outcome.exception()  # mark retrieved: nobody may be awaiting the result
        self._wakeup.set()

    @property
    def done(self) -> bool:
        """True once a result (or failure) arrived."""
        return self._outcome.done()

    async def result(self) -> Any:
        """Wait for the result values; raises :class:`ActionError` unless SUCCEEDED."""
        outcome = await asyncio.shield(self._outcome)
        if not outcome.result or outcome.status not in (GOAL_SUCCEEDED, 0):
            raise ActionError(outcome.values, action=self.action, status=outcome.status)
        return self._normalized("result", outcome.values)

    def _normalized(self, part: Literal["result", "feedback"], values: Any) -> Any:
        try:
            return normalize_action_values(self._registry, self.action_type, part, values)
        except SchemaError as exc:
            logger.warning("%s %s of %s kept as received: %s", self.action, part, self.id, exc)
            return values

    async def feedback(self) -> AsyncIterator[Any]:
        """Yield feedback values in arrival order until the goal finishes."""
        while True:
            while self._feedback:
                yield self._feedback.popleft()
            if self._outcome.done():
                return
            self._wakeup.clear()
            await self._wakeup.wait()

    async def cancel(self) -> None:
        """Ask the server to cancel; :meth:`result` then reports the final status."""
        if not self.done:
            await self._cancel(self)
