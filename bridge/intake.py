"""One connection's inbound frames, handled in order per topic while slow ones run elsewhere.

Every frame is decoded on the event loop: the JSON and CBOR parsers are C code that holds the
GIL, so a worker thread would stall the loop just as long and add a thread hop on top. What a
worker does win is validation that runs in Python or outside the GIL: a publish of at least
`offload_threshold_bytes` whose message is not mostly bytes or arrays (a JSON scan's base64,
400 nested radar detections) is checked on a worker (`BridgeCore.offload`), and the frame goes
to the core with the result (`InboundFrame.checked`).

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
from dataclasses import dataclass, replace

from bridge.core import BridgeCore
from bridge.effects import Effect
from bridge.inbound import InboundFrame, read_frame
from bridge.validation import CheckedMessage, PublishCheck
from schemas.errors import SchemaError
from schemas.values import JsonValue

# The key of a frame that keeps its place relative to every other frame of its connection.
BARRIER = None


def topic_key(topic: JsonValue) -> str | None:
    """The key ordering a publish on `topic` (its absolute name), BARRIER if not a name."""
    if not isinstance(topic, str):
        return BARRIER
    name = topic.strip()
    return name if name.startswith("/") else "/" + name


def message_key(message: JsonValue) -> str | None:
    """A decoded frame's ordering key: the topic of a publish, else BARRIER."""
    if isinstance(message, dict) and message.get("op") == "publish":
        return topic_key(message.get("topic"))
    return BARRIER


@dataclass(slots=True)
class Entry:
    """A frame waiting for its turn: `ready` once its check on the worker has ended."""

    key: str | None
    frame: InboundFrame
    ready: bool = True
    problem: str | None = None  # the worker failed (a bug): the frame is refused with this


class Intake:
    """The inbound pipeline of one connection; `apply` carries out the core's effects."""

    def __init__(
        self,
        client_id: int,
        core: BridgeCore,
        pool: Executor,
        apply: Callable[[list[Effect]], None],
    ) -> None:
        self._client_id = client_id
        self._core = core
        self._pool = pool
        self._apply = apply
        self._waiting: deque[Entry] = deque()
        self._moved = asyncio.Event()  # set whenever waiting frames were handled
        self.pending_bytes = 0  # wire bytes of the frames taken but not handled
        self.closed = False

    @property
    def in_flight(self) -> int:
        """Frames taken but not yet handled (checked on a worker, or waiting behind one)."""
        return len(self._waiting)

    async def settled(self, frames: int, nbytes: int) -> None:
        """Return once at most `frames` frames and `nbytes` bytes wait to be handled."""
        while (len(self._waiting) > frames or self.pending_bytes > nbytes) and not self.closed:
            self._moved.clear()
            await self._moved.wait()

    def take(self, data: bytes | str, arrived_ns: int) -> None:
        """Handle a frame now, or start its check and handle it when its turn comes."""
        try:
            frame = read_frame(data, arrived_ns)
        except SchemaError as exc:
            self._apply(self._core.receive_invalid(self._client_id, str(exc), time.time_ns()))
            return
        work = self._core.offload(frame, arrived_ns)  # the check's 'now': the frame's arrival
        if work is not None:
            self._start_worker(Entry(message_key(frame.message), frame, ready=False), work)
        elif not self._waiting:  # (the usual case: nothing to keep an order with)
            self._handle(frame)
        elif self._must_wait(key := message_key(frame.message), self._waiting):
            self._wait(Entry(key, frame))
        else:
            self._handle(frame)

    def _wait(self, entry: Entry) -> None:
        self._waiting.append(entry)
        self.pending_bytes += entry.frame.wire_bytes

    def _start_worker(self, entry: Entry, work: PublishCheck) -> None:
        try:
            future = asyncio.get_running_loop().run_in_executor(self._pool, work.run)
        except RuntimeError:  # the pool has shut down: the server is stopping
            self.closed = True
            return
        self._wait(entry)
        future.add_done_callback(lambda done: self._checked(entry, done))

    def _checked(self, entry: Entry, done: asyncio.Future[CheckedMessage]) -> None:
        if done.cancelled():  # the server is stopping
            self.closed = True
        elif (exc := done.exception()) is not None:
            entry.problem = repr(exc)
        else:
            entry.frame = replace(entry.frame, checked=done.result())
        entry.ready = True
        self.run_ready()

    def run_ready(self) -> None:
        """Handle every frame that no earlier unhandled frame holds back."""
        held: deque[Entry] = deque()
        while self._waiting:
            entry = self._waiting.popleft()
            if self.closed:
                continue
            if not entry.ready or (held and self._must_wait(entry.key, held)):
                held.append(entry)
                continue
            self.pending_bytes -= entry.frame.wire_bytes
            if entry.problem is not None:
                self._apply(
                    self._core.receive_invalid(self._client_id, entry.problem, time.time_ns())
                )
            else:
                self._handle(entry.frame)
        self._waiting = held
        self._moved.set()

    @staticmethod
    def _must_wait(key: str | None, earlier: deque[Entry]) -> bool:
        if key is BARRIER:
            return True
        return any(e.key is BARRIER or e.key == key for e in earlier)

    def _handle(self, frame: InboundFrame) -> None:
        self._apply(self._core.receive_frame(self._client_id, frame, time.time_ns()))
