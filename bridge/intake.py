"""One connection's inbound frames, handled in order per topic while slow ones run elsewhere.

Every frame is decoded on the event loop: the JSON and CBOR parsers are C code that holds the
GIL, so a worker thread would stall the loop just as long and add a thread hop on top. What a
worker does win is validation that runs in Python or outside the GIL: a publish of at least
`offload_bytes` whose message is not mostly bytes or arrays (a JSON scan's base64, 400 nested
radar detections) is validated on a worker (`BridgeCore.needs_worker`, `prepare_decoded`).

Meanwhile later frames of the same connection keep coming, and a later frame waits for the
one on the worker only if it has to: when both publish on the same topic (ROS keeps a topic's
order), or when either is not a publish (advertise, subscribe, service ops keep their place
relative to everything). So an IMU sample sent right after a scan on the same connection is
relayed while the scan is still being validated.
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Executor
from dataclasses import dataclass, field
from typing import Any

from bridge.core import BridgeCore
from bridge.effects import Effect
from bridge.inbound import decode_frame
from schemas.errors import SchemaError

# The key of a frame that keeps its place relative to every other frame of its connection.
BARRIER = None
_PENDING = object()


def topic_key(topic: Any) -> str | None:
    """The key ordering a publish on `topic` (its absolute name), BARRIER if not a name."""
    if not isinstance(topic, str):
        return BARRIER
    topic = topic.strip()
    return topic if topic.startswith("/") else "/" + topic


def message_key(message: Any) -> str | None:
    """A decoded frame's ordering key: the topic of a publish, else BARRIER."""
    if isinstance(message, dict) and message.get("op") == "publish":
        return topic_key(message.get("topic"))
    return BARRIER


@dataclass(slots=True)
class Entry:
    """A frame waiting for its turn: decoded (`message`) or still on the worker."""

    key: str | None
    arrived_ns: int
    wire_bytes: int
    message: Any = field(default=_PENDING)
    problem: str | None = None

    @property
    def ready(self) -> bool:
        return self.message is not _PENDING or self.problem is not None


class Intake:
    """The inbound pipeline of one connection; `apply` carries out the core's effects."""

    def __init__(self, client_id: int, core: BridgeCore, pool: Executor, offload_bytes: int,
                 apply: Callable[[list[Effect]], None],
                 arrived: Callable[[int, int], None]) -> None:
        self._client_id = client_id
        self._core = core
        self._pool = pool
        self._offload_bytes = offload_bytes
        self._apply = apply
        self._arrived = arrived  # tells the tracer which frame the core handles next
        self._waiting: deque[Entry] = deque()
        self._moved = asyncio.Event()  # set whenever waiting frames were handled
        self.pending_bytes = 0  # wire bytes of the frames taken but not handled
        self.closed = False

    @property
    def in_flight(self) -> int:
        """Frames taken but not yet handled (decoding on a worker, or waiting behind one)."""
        return len(self._waiting)

    async def settled(self, frames: int, nbytes: int) -> None:
        """Return once at most `frames` frames and `nbytes` bytes wait to be handled."""
        while (len(self._waiting) > frames or self.pending_bytes > nbytes) and not self.closed:
            self._moved.clear()
            await self._moved.wait()

    def take(self, data: bytes | str, arrived_ns: int) -> None:
        """Handle a frame now, or start its validation and handle it when its turn comes."""
        try:
            message = decode_frame(data)
        except SchemaError as exc:
            self._apply(self._core.receive_invalid(self._client_id, str(exc), time.time_ns()))
            return
        key = message_key(message)
        wire_bytes = len(data)
        if wire_bytes >= self._offload_bytes and self._core.needs_worker(message, wire_bytes):
            self._start_worker(key, message, arrived_ns, wire_bytes)
        elif self._waiting and self._must_wait(key, self._waiting):
            self._waiting.append(Entry(key, arrived_ns, wire_bytes, message))
            self.pending_bytes += wire_bytes
        else:
            self._handle(message, arrived_ns, wire_bytes)

    def _start_worker(self, key: str | None, message: Any, arrived_ns: int,
                      wire_bytes: int) -> None:
        try:
            future = asyncio.get_running_loop().run_in_executor(
                self._pool, self._core.prepare_decoded, message, wire_bytes, time.time_ns())
        except RuntimeError:  # the pool has shut down: the server is stopping
            self.closed = True
            return
        entry = Entry(key, arrived_ns, wire_bytes)
        self._waiting.append(entry)
        self.pending_bytes += wire_bytes
        future.add_done_callback(lambda done: self._prepared(entry, done))

    def _prepared(self, entry: Entry, done: asyncio.Future[Any]) -> None:
        if done.cancelled():  # the server is stopping
            self.closed = True
        elif (exc := done.exception()) is not None:
            entry.problem = str(exc) if isinstance(exc, SchemaError) else repr(exc)
        else:
            entry.message = done.result()
        self.run_ready()

    def run_ready(self) -> None:
        """Handle every decoded frame that no earlier unhandled frame holds back."""
        held: deque[Entry] = deque()
        while self._waiting:
            entry = self._waiting.popleft()
            if self.closed:
                continue
            if not entry.ready or (held and self._must_wait(entry.key, held)):
                held.append(entry)
                continue
            self.pending_bytes -= entry.wire_bytes
            if entry.problem is not None:
                self._apply(self._core.receive_invalid(self._client_id, entry.problem,
                                                       time.time_ns()))
            else:
                self._handle(entry.message, entry.arrived_ns, entry.wire_bytes)
        self._waiting = held
        self._moved.set()

    @staticmethod
    def _must_wait(key: str | None, earlier: deque[Entry]) -> bool:
        if key is BARRIER:
            return True
        return any(e.key is BARRIER or e.key == key for e in earlier)

    def _handle(self, message: Any, arrived_ns: int, wire_bytes: int) -> None:
        self._arrived(arrived_ns, wire_bytes)
        self._apply(self._core.receive_decoded(self._client_id, message, time.time_ns()))
