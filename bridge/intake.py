"""One connection's inbound frames, handled in order per topic while big ones decode elsewhere.

Small frames are decoded and handled on the event loop at once. A frame of `offload_bytes` or
more is decoded and validated on a worker thread (`BridgeCore.prepare`); meanwhile later frames
of the same connection keep coming. A later frame waits for the big one only if it has to:
when both publish on the same topic (ROS keeps a topic's order), or when either is not a
publish whose topic is known (advertise, subscribe, service ops and frames whose topic cannot
be read cheaply keep their place relative to everything). So an IMU sample sent right after a
5 MB scan on the same connection is relayed while the scan is still being decoded.

A big frame's topic is read from its first bytes (`sniff_topic`), which costs microseconds;
clients that write `op`, `id` and `topic` before `msg` (roslibpy, roslibjs, riverbridge's own)
get the overtaking, any other order is simply handled in arrival order.
"""

from __future__ import annotations

import asyncio
import re
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
_SNIFF_CHARS = 512  # the envelope keys come first in every client we know of
_JSON_PAIR = re.compile(
    rb'\s*"(op|id|topic|latch|type|queue_size)"\s*:\s*("(?:[^"\\]|\\.)*"|[-+\w.]+)\s*,')


def topic_key(topic: Any) -> str | None:
    """The key ordering a publish on `topic` (its absolute name), None if it is not a name."""
    if not isinstance(topic, str):
        return BARRIER
    topic = topic.strip()
    return topic if topic.startswith("/") else "/" + topic


def message_key(message: Any) -> str | None:
    """A decoded frame's ordering key: the topic of a publish, else BARRIER."""
    if isinstance(message, dict) and message.get("op") == "publish":
        return topic_key(message.get("topic"))
    return BARRIER


def sniff_topic(data: bytes | str) -> str | None:
    """The topic of a publish frame read from its first bytes, or BARRIER if not found there.

    JSON: the leading scalar members of the top-level object (`op`, `id`, `topic`, ...).
    CBOR: the leading text-string members of the top-level map.
    """
    head = data[:_SNIFF_CHARS]
    raw = head.encode("utf-8", "replace") if isinstance(head, str) else bytes(head)
    stripped = raw.lstrip()
    if stripped[:1] == b"{":
        return _sniff_json(stripped)
    return _sniff_cbor(raw)


def _sniff_json(text: bytes) -> str | None:
    members: dict[bytes, bytes] = {}
    position = 1
    while (match := _JSON_PAIR.match(text, position)) is not None:
        members[match.group(1)] = match.group(2)
        position = match.end()
    topic = members.get(b"topic", b"")
    if members.get(b"op") != b'"publish"' or not topic.startswith(b'"') or b"\\" in topic:
        return BARRIER
    return topic_key(topic[1:-1].decode("utf-8", "replace"))


def _cbor_text(data: bytes, position: int) -> tuple[str, int] | None:
    """A definite-length CBOR text string at `position`: (text, next position)."""
    if position >= len(data):
        return None
    initial = data[position]
    if 0x60 <= initial <= 0x77:
        length, start = initial - 0x60, position + 1
    elif initial == 0x78 and position + 1 < len(data):
        length, start = data[position + 1], position + 2
    else:
        return None
    if start + length > len(data):
        return None
    return data[start:start + length].decode("utf-8", "replace"), start + length


def _sniff_cbor(data: bytes) -> str | None:
    if not data or not (0xa1 <= data[0] <= 0xb7 or data[0] in (0xb8, 0xbf)):
        return BARRIER
    position = 2 if data[0] == 0xb8 else 1
    members: dict[str, str] = {}
    while (key := _cbor_text(data, position)) is not None and key[0] in ("op", "topic", "id"):
        value = _cbor_text(data, key[1])
        if value is None:
            break
        members[key[0]], position = value
    if members.get("op") != "publish" or "topic" not in members:
        return BARRIER
    return topic_key(members["topic"])


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
        """Handle a frame now, or start its decode and handle it when its turn comes."""
        if len(data) >= self._offload_bytes:
            self._start_big(data, arrived_ns)
            return
        try:
            message = decode_frame(data)
        except SchemaError as exc:
            self._apply(self._core.receive_invalid(self._client_id, str(exc), time.time_ns()))
            return
        key = message_key(message)
        if self._waiting and self._must_wait(key, self._waiting):
            self._waiting.append(Entry(key, arrived_ns, len(data), message))
            self.pending_bytes += len(data)
            return
        self._handle(message, arrived_ns, len(data))

    def _start_big(self, data: bytes | str, arrived_ns: int) -> None:
        entry = Entry(sniff_topic(data), arrived_ns, len(data))
        self._waiting.append(entry)
        self.pending_bytes += len(data)
        future = asyncio.get_running_loop().run_in_executor(
            self._pool, self._core.prepare, data, time.time_ns())
        future.add_done_callback(lambda done: self._prepared(entry, done))

    def _prepared(self, entry: Entry, done: asyncio.Future[Any]) -> None:
        if done.cancelled():
            entry.problem = "decode cancelled"
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
