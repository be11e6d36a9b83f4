"""The inbound data path of a websocket: whole messages from the parser straight to a handler.

websockets' asyncio connection queues every parsed frame in an `Assembler` and wakes a task
awaiting `recv()` for each message (a future, a task step and a loop turn per frame). Here the
frames go from `data_received` to the connection's `Reader` in the same call: a message is
handled as soon as its last frame is parsed, and the frames written while handling a whole
chunk of the socket leave together. websockets still does everything else: the handshake,
HTTP, TLS, control frames, the closing handshake, `max_size` (its parser refuses an oversize
frame or message with 1009 and closes). What the Assembler did besides queueing is done here
as it did it: fragments joined (at most `MAX_FRAGMENTS`, else 1009), text decoded as UTF-8
(else 1007).

Once the handshake is done, the plain data frames do not even go through websockets' parser:
a `FrameScanner` (`frame_scan.py`) splits the bytes at frame boundaries, unmasks those frames
itself and hands every other frame, whole, to websockets, which then only ever parses whole
frames. It takes over only at a clean point (the request ended a chunk), and websockets alone
reads the connection again once it is no longer open.

The reader's turns and waits (the edge's fair turns, pacing by backed-up subscribers, holds)
become pauses of the transport's reading: a reader that has worked `TURN_S` in one chunk, or
that `must_wait`, keeps the chunk's remaining messages, pauses reading and goes on after one
loop turn (`call_soon`) or once `wait()` returns. Messages read before the connection closed
are still handled, in order, as `recv()` still returned them.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections import deque
from collections.abc import Awaitable, Callable
from typing import Any

from websockets.asyncio.messages import MAX_FRAGMENTS
from websockets.asyncio.server import ServerConnection
from websockets.frames import CloseCode, Frame, Opcode
from websockets.protocol import Event, State

from bridge.frame_scan import RAW, TEXT, FrameScanner

logger = logging.getLogger("bridge.server")

# Longest stretch a reader handles the messages of one chunk before it lets the loop write and
# read elsewhere.
TURN_S = 0.001

Message = str | bytes


class Reader:
    """Hands one connection's messages to `handle`, in order, in fair turns.

    After each message `must_wait()` is asked; if it says so, reading pauses until `wait()`
    returns. `done` resolves once the connection has closed and every message read before it
    was handled (with the exception `handle` raised, if one did: the connection is then failed
    with 1011, as websockets does when a handler fails).
    """

    def __init__(
        self,
        connection: FrameConnection,
        handle: Callable[[Message], None],
        must_wait: Callable[[], bool],
        wait: Callable[[], Awaitable[None]],
    ) -> None:
        self._connection = connection
        self._handle = handle
        self._must_wait = must_wait
        self._wait = wait
        self._loop = asyncio.get_running_loop()
        self._pending: deque[Message] = deque()
        self._paused = False
        self._closed = False
        self._turn_started = time.perf_counter()
        self._waiter: asyncio.Task[None] | None = None
        self.done: asyncio.Future[None] = self._loop.create_future()

    def start_turn(self) -> None:
        """A new chunk arrived from the socket: its messages get a turn of their own."""
        self._turn_started = time.perf_counter()

    def feed(self, message: Message) -> None:
        if self.done.done():  # failed or cancelled: nothing more is handled
            return
        if self._paused:
            self._pending.append(message)
            return
        self._run(message)

    def _run(self, message: Message) -> None:
        """Handle one message; pause if its turn is over or the edge asks to wait."""
        try:
            self._handle(message)
            waits = self._must_wait()
        except Exception as exc:  # a bug: end the connection as a failed handler would
            self._failed(exc)
            return
        if waits:
            self._pause()
            self._waiter = self._loop.create_task(self._wait_then_go_on())
        elif time.perf_counter() - self._turn_started > TURN_S:
            self._pause()
            self._loop.call_soon(self._go_on)

    def _pause(self) -> None:
        self._paused = True
        if not self._closed:
            self._connection.transport.pause_reading()

    async def _wait_then_go_on(self) -> None:
        try:
            await self._wait()
        except Exception as exc:
            self._failed(exc)
            return
        finally:
            self._waiter = None
        self._go_on()

    def _go_on(self) -> None:
        """Handle what waited, in a new turn, then read the socket again."""
        if self.done.done():
            return
        self._paused = False
        self.start_turn()
        while self._pending and not self._paused and not self.done.done():
            self._run(self._pending.popleft())
        if self._paused or self.done.done():
            return
        if self._closed:
            self.done.set_result(None)
        else:
            self._connection.transport.resume_reading()

    def closed(self) -> None:
        """The connection is gone: finish once what it read has been handled."""
        self._closed = True
        if not self._paused and not self.done.done():
            self.done.set_result(None)

    def cancel(self) -> None:
        """The handler stops waiting (the server is stopping): drop what waits."""
        self._pending.clear()
        if self._waiter is not None:
            self._waiter.cancel()
        if not self.done.done():
            self.done.set_result(None)

    def _failed(self, exc: BaseException) -> None:
        self._pending.clear()
        self._connection.fail(CloseCode.INTERNAL_ERROR, "internal error")
        if not self.done.done():
            self.done.set_exception(exc)


class FrameConnection(ServerConnection):
    """A `ServerConnection` whose data messages go to its `Reader` as they are parsed, not
    through `recv()` (which must not be used on it)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._parts: list[Frame] = []
        self._reader: Reader | None = None
        self._early: list[Message] = []  # messages parsed before a reader was attached
        self._failed = False
        self._scanner: FrameScanner | None = None  # set once the handshake leaves a clean point
        self._request_tail = b""  # the handshake's last bytes, to find where the request ends

    def attach(self, reader: Reader) -> None:
        """Give messages to `reader` from now on (and those that came before it)."""
        self._reader = reader
        early, self._early = self._early, []
        reader.start_turn()
        for message in early:
            reader.feed(message)
        if self.protocol.state is State.CLOSED:
            reader.closed()

    def fail(self, code: int, reason: str) -> None:
        """Fail the connection (RFC 6455 7.1.7): a close frame with `code`, then no more."""
        self._failed = True
        self._parts = []
        if self.protocol.state is State.OPEN:
            self.protocol.fail(code, reason)
            self.send_data()

    def data_received(self, data: bytes) -> None:
        if self._reader is not None:
            self._reader.start_turn()
        scanner = self._scanner
        if scanner is not None:
            if self.protocol.state is State.OPEN:
                self._scan(scanner, data)
                return
            # Closing, or bytes before the handshake's answer: websockets' alone from here on.
            self._scanner = None
            data = scanner.take_rest() + data
        handshaking = self.request is None
        super().data_received(data)
        if handshaking:
            self._after_request_bytes(data)

    def _after_request_bytes(self, data: bytes) -> None:
        """Scan frames from now on if the request ended exactly at this chunk's end: then
        websockets' parser waits at a frame boundary with nothing buffered."""
        seen = self._request_tail + data
        if self.request is None:
            self._request_tail = seen[-3:]
            return
        end = seen.find(b"\r\n\r\n") + 4
        if end == len(seen) >= 4 and not self.protocol.reader.buffer:
            sizes = (self.protocol.max_message_size, self.protocol.max_fragment_size)
            self._scanner = FrameScanner(min((s for s in sizes if s is not None), default=None))

    def _scan(self, scanner: FrameScanner, data: bytes) -> None:
        """Deliver the chunk's plain data frames, hand the other frames to websockets, in
        order; once the connection is no longer open, the rest goes to websockets."""
        scanner.feed(data)
        while (frame := scanner.next_frame()) is not None:
            kind, payload = frame
            if kind is RAW:
                super().data_received(payload)
            else:
                self._deliver(kind is TEXT, payload)
            if self.protocol.state is not State.OPEN:
                self._scanner = None
                rest = scanner.take_rest()
                if rest:
                    super().data_received(rest)
                return

    def eof_received(self) -> None:
        scanner, self._scanner = self._scanner, None
        if scanner is not None and (rest := scanner.take_rest()):
            super().data_received(rest)  # a partial frame: websockets fails it as before
        super().eof_received()

    def process_event(self, event: Event) -> None:
        if self.request is None:  # the handshake request
            super().process_event(event)
            return
        assert isinstance(event, Frame)
        opcode = event.opcode
        if opcode is Opcode.PONG:
            self.acknowledge_pings(bytes(event.data))
        elif self._failed or not (
            opcode is Opcode.TEXT or opcode is Opcode.BINARY or opcode is Opcode.CONT
        ):
            return
        elif event.fin and not self._parts:
            self._deliver(opcode is Opcode.TEXT, event.data)
        else:
            self._assemble(event)

    def _assemble(self, frame: Frame) -> None:
        parts = self._parts
        parts.append(frame)
        if len(parts) > MAX_FRAGMENTS:
            self.fail(CloseCode.MESSAGE_TOO_BIG, "too many fragments")
        elif frame.fin:
            self._parts = []
            self._deliver(parts[0].opcode is Opcode.TEXT, b"".join(f.data for f in parts))

    def _deliver(self, text: bool, data: bytes | bytearray | memoryview) -> None:
        message: Message
        if text:
            try:
                message = bytes(data).decode()
            except UnicodeDecodeError as exc:
                self.set_connection_exc(exc)
                self.fail(CloseCode.INVALID_DATA, f"{exc.reason} at position {exc.start}")
                return
        else:
            message = bytes(data)
        if self._reader is None:
            self._early.append(message)
        else:
            self._reader.feed(message)

    def connection_lost(self, exc: Exception | None) -> None:
        super().connection_lost(exc)
        if self._reader is not None:
            self._reader.closed()


async def read_until_closed(reader: Reader, connection: FrameConnection) -> None:
    """Attach `reader` and return once the connection has closed and its messages are handled;
    raises what `handle` raised."""
    connection.attach(reader)
    try:
        await asyncio.shield(reader.done)
    except asyncio.CancelledError:
        reader.cancel()
        raise
