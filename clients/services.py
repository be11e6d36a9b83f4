"""Serving the services this client advertises, and normalizing service values by type."""

from __future__ import annotations

import asyncio
import logging
import time
from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable
from typing import Any, Generic, Literal, TypeVar

from clients.errors import ConnectionClosed
from clients.events import ServiceRequest
from clients.protocol import ClientProtocol
from clients.wire import Frame
from schemas.message import normalize
from schemas.registry import TypeRegistry

logger = logging.getLogger(__name__)

Handler = Callable[[dict[str, Any]], Awaitable[dict[str, Any] | None]]
HandlerT = TypeVar("HandlerT")


def normalize_service_values(
    registry: TypeRegistry, type: str | None, part: Literal["request", "response"], values: Any
) -> Any:
    """Canonical form of a request/response when ``type`` is a known service; else as is."""
    if type is None or not isinstance(values, dict) or not registry.has_service(type):
        return values
    spec = getattr(registry.service(type), part)
    return normalize(spec, values, now_ns=time.time_ns())


class HandlerHost(ABC, Generic[HandlerT]):
    """What serving services and serving actions share: a handler and its type per name, the
    registry requests are normalised with, the send answers leave through, and the tasks
    still running (cancelled when the client closes)."""

    def __init__(self, registry: TypeRegistry, send: Callable[[Frame], Awaitable[None]]) -> None:
        self._registry = registry
        self._send = send
        self._handlers: dict[str, tuple[HandlerT, str]] = {}

    def add(self, name: str, type: str, handler: HandlerT) -> None:
        """Route the calls or goals of ``name`` to ``handler`` (replacing any previous one)."""
        self._handlers[name] = (handler, type)

    def remove(self, name: str) -> None:
        """Stop serving ``name``; calls and goals already running still answer."""
        self._handlers.pop(name, None)

    @abstractmethod
    def _running_tasks(self) -> list[asyncio.Task[None]]:
        """The handler tasks still running, to cancel when the client closes."""

    async def cancel_all(self) -> None:
        """Cancel running handlers (client closing)."""
        tasks = self._running_tasks()
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)


class ServiceHost(HandlerHost[Handler]):
    """Runs the handler of each incoming ``call_service`` in its own task and answers it.

    Handlers of concurrent calls run concurrently; a slow handler delays only its own caller.
    A handler exception becomes ``result: false`` with the exception text as ``values``
    (what rosbridge itself answers for a failing ROS service).
    """

    def __init__(self, registry: TypeRegistry, send: Callable[[Frame], Awaitable[None]]) -> None:
        super().__init__(registry, send)
        self._tasks: set[asyncio.Task[None]] = set()

    def serve(self, request: ServiceRequest) -> None:
        """Start answering ``request`` (called from the reader; never blocks it)."""
        entry = self._handlers.get(request.service)
        if entry is None:
            logger.warning("call of %s, which has no handler here", request.service)
            return
        task = asyncio.create_task(self._answer(request, *entry), name=f"serve {request.service}")
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _answer(self, request: ServiceRequest, handler: Handler, type: str) -> None:
        try:
            args = normalize_service_values(self._registry, type, "request", request.args)
            values = await handler(args)
            frame = ClientProtocol.service_response(
                request, {} if values is None else values, result=True
            )
        except Exception as exc:
            logger.warning("handler of %s failed: %r", request.service, exc)
            frame = ClientProtocol.service_response(request, str(exc) or repr(exc), result=False)
        try:
            await self._send(frame)
        except ConnectionClosed as exc:
            logger.warning(
                "could not answer %s (id %s): %s", request.service, request.request_id, exc
            )

    def _running_tasks(self) -> list[asyncio.Task[None]]:
        return list(self._tasks)
