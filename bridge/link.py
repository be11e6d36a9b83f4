"""The edge's outgoing half of one connection: write-through, a byte-bounded backlog, pacing.

A message for a client whose socket has room and nothing waiting is framed and handed to the
transport at once, in the same loop turn that produced it: no queue, no task switch. Frames
written in one turn leave in one `transport.write` when the turn ends (one system call for a
burst instead of one per message). Only when the socket is backed up do messages wait in the
client's `SendQueue`, bounded in bytes; past the bound each topic loses its oldest waiting
message, and a subscription with `queue_length` keeps only its newest, counted
(`bridge.sendqueue`).

Room is what the link drains soon: the bytes not yet sent (the transport's and the kernel's
unsent bytes, `SIOCOUTQNSD`) may be at most `ROOM_HORIZON_S` of the client's measured goodput
(`bridge.goodput`), between `MIN_ROOM_BYTES` and 1 MiB (1 MiB until measured: a client on
loopback never sees less). So on a thin link a scan is not handed to the socket whole: its
fragments go one at a time, and an IMU sample waits for at most one fragment. While the kernel
holds the surplus a timer, not the transport, says when to look again.

A frame of `BIG_BYTES` or more waits for this link's turn (`bridge.big_writes`): fanned out to
sixteen links, the copies go out two at a time; small messages pass it meanwhile.

Large messages whose encode is not just C code holding the GIL are encoded on a worker thread
(JSON with base64, PNG, CDR); their topic waits for the encode (order per topic), other topics
keep flowing past it.

Publishers are paced by their subscribers: a link whose queue holds more than `pause_bytes` asks
the readers feeding it to stop reading until it drains (TCP backpressure then slows the
publisher). Only the queue counts: one big message in the socket's buffer (a scan the client
is still reading) is no reason to hold up the publisher's next frames.
A link that makes no progress for `STALL_S`, or stays backed up longer than `SLOW_S`, is a slow
reader: nobody waits for it any more until it has caught up, and it drops instead.

A message that cannot be encoded is lost alone: one line names client, topic and error, rate
limited per client like bad input (`bridge.problems`), with a summary of the rest.
"""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import logging
import struct
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import Executor

from websockets.asyncio.server import ServerConnection
from websockets.protocol import State

from bridge.big_writes import BIG_BYTES, BigWriteTurns
from bridge.effects import Send
from bridge.goodput import GoodputMeter, LinkHealth
from bridge.outgoing import CBOR, CBOR_RAW, Delivery, WireFrame, render
from bridge.problems import NS_PER_S, ProblemLog
from bridge.reply_budget import ReplyBudget
from bridge.sendqueue import SendQueue, Waiting
from schemas.safety import echo, safe_text

logger = logging.getLogger("bridge.server")

# Bytes the transport may hold for a client before messages wait in its queue instead: a few
# thousand small frames, or one slice of a scan (the transport's own high-water mark too; less
# when the client's bound is small).
WRITE_HIGH_WATER = 1024 * 1024
# Writes of at least this size are handed to the transport on their own, not joined.
JOIN_LIMIT = 64 * 1024
# A backed-up link that accepted no byte for this long is not waited for (it may never read).
STALL_S = 0.2
# A link backed up for longer than this is a slow reader: it drops rather than pace publishers.
SLOW_S = 2.0
POLL_S = 0.01  # how often a paused reader looks at a link's progress
# Unsent bytes a socket may hold, in seconds of its client's goodput: an IMU sample written now
# waits this long plus one fragment (docs/bridge.md, "Over a thin link").
ROOM_HORIZON_S = 0.02
MIN_ROOM_BYTES = 16 * 1024  # never less: a link of 6 Mbit/s or less still gets whole frames
SLACK_BYTES = 4 * 1024  # a frame larger than the room goes once no more than this is unsent
SIOCOUTQNSD = 0x894B  # Linux: bytes in a TCP socket's send queue not yet sent
UNSENT_FRESH_S = 0.001  # the kernel's figure is read at most once a millisecond per link
PACE_MIN_S, PACE_MAX_S = 0.001, 0.02  # when the kernel holds the surplus, look again within

Delivered = Callable[[int, Delivery, int, int], None]  # client, delivery, wire bytes, ns


def frame_header(text: bool, size: int) -> bytes:
    """The header of an unmasked, final server frame of `size` bytes (RFC 6455 §5.2).

    websockets' `send_text` builds a `Frame`, checks it and copies header and payload into a
    new buffer; a 5.5 MB scan fanned out to 16 clients was copied 16 times that way.
    """
    first = 0x81 if text else 0x82
    if size < 126:
        return bytes((first, size))
    if size < 65536:
        return struct.pack("!BBH", first, 126, size)
    return struct.pack("!BBQ", first, 127, size)


def estimated_size(send: Send) -> int:
    """Frame bytes of a large item before it is encoded: JSON spells bytes in base64."""
    item = send.item
    binary = isinstance(item, Delivery) and item.encoding in (CBOR, CBOR_RAW)
    return item.size_hint if binary else item.size_hint * 4 // 3


class ClientLink:
    """Outgoing side of one websocket: `offer` each `Send`; `close` when the client leaves."""

    def __init__(
        self,
        client_id: int,
        ws: ServerConnection,
        *,
        limit_bytes: int,
        pool: Executor,
        offload_bytes: int,
        reply_budget_bytes: int,
        delivered: Delivered,
        over_budget: Callable[[str], None],
        node: str | None = None,
        turns: BigWriteTurns | None = None,
    ) -> None:
        self.client_id = client_id
        self.node = node or f"client {client_id}"  # names the client in log lines
        self.ws = ws
        self.queue = SendQueue(limit_bytes)
        # Answers are never dropped: those queued unread are bounded by closing the client.
        self.replies = ReplyBudget(reply_budget_bytes)
        self.over_budget = False
        self._over_budget = over_budget
        # What the transport may hold before messages queue (a quarter of a small bound), and
        # the queue from which publishers feeding this link wait for it (1 MiB by default).
        self.max_room_bytes = self.room_bytes = min(WRITE_HIGH_WATER, limit_bytes // 4)
        self.pause_bytes = limit_bytes // 16
        self.goodput = GoodputMeter()
        self.reduced: Counter[str] = Counter()  # point clouds thinned, per topic
        self.frames_sent = 0
        self.closed = False  # the client has left
        self.closing = False  # the bridge is closing the connection
        self._loop = asyncio.get_running_loop()
        self._pool = pool
        self._offload_bytes = offload_bytes
        self._delivered = delivered
        self._transport = ws.transport
        self._transport.set_write_buffer_limits(high=self.room_bytes)  # drain() wakes at 1/4
        sock = self._transport.get_extra_info("socket")
        self._fd: int | None = sock.fileno() if sock is not None else None
        self._kernel_unsent = 0
        self._unsent_read_at = float("-inf")
        self._pace_timer: asyncio.TimerHandle | None = None
        self._protocol = ws.protocol
        self._busy: set[str | None] = set()  # streams with a message being encoded
        self._fragment_seq = 0  # numbers fragment ids of messages that have no id of their own
        self._corked = 0  # bytes framed this turn, not yet handed to the transport
        self._handed = 0  # bytes handed to the transport since the start
        self._flush_pending = False
        self._just_delivered: list[tuple[Delivery, int]] = []
        self._drain_task: asyncio.Task[None] | None = None
        self._progress = asyncio.Event()
        self._backed_up_since: float | None = None
        self._stalled = False
        self._problems = ProblemLog()  # messages that could not be encoded
        self._summary_timer: asyncio.TimerHandle | None = None
        # Large frames take turns with other links' (`bridge.big_writes`): the bytes of the
        # queued one waiting for its turn (they do not pace publishers, as if in the socket),
        # and whether one went out in this link's current turn.
        self._turns = turns if turns is not None else BigWriteTurns(slots=1 << 30)
        self._waiting_turn_bytes = 0
        self._big_out = False
        # Frames are built here, not by websockets, when nothing transforms them (no
        # extension, no debug log): a server frame is a 2-10 byte header and the payload.
        self._own_framing = not self._protocol.extensions and not self._protocol.debug

    # -- sending -----------------------------------------------------------------------------

    def offer(self, send: Send) -> bool:
        """Write `send` now or queue it; True if publishers feeding this link should pause."""
        if self.closed or self.closing:
            return False
        if (
            not len(self.queue)
            and send.drop_key not in self._busy
            and self._has_room()
            and not self._needs_worker(send)
        ):
            frames = self._render(send)
            if frames is None:
                return False
            if len(frames) == 1 and self._may_write(send, frames[0]):
                self._write(send, frames)
                return False
            self._enqueue(send, frames)  # fragments leave one at a time, others between them
        else:
            self._enqueue(send)
        self._service()
        return self.wants_pause()

    def _needs_worker(self, send: Send) -> bool:
        """Encode on a worker? Only large messages whose encode leaves the GIL for part of
        the time (base64 for JSON, zlib for PNG) or runs in Python (CDR): CBOR's encoder, and
        the JSON of an answer, are C code holding the GIL, so a worker would stall the loop as
        long and add a thread hop."""
        item = send.item
        if item.size_hint < self._offload_bytes or not isinstance(item, Delivery):
            return False
        return item.encoding != CBOR or item.reduce is not None  # numpy's sort leaves the GIL

    def _enqueue(self, send: Send, frames: list[WireFrame] | None = None) -> None:
        if frames is None and not self._needs_worker(send):
            frames = self._render(send)  # small: exact size now; the encode is shared anyway
            if frames is None:
                return
        nbytes = estimated_size(send) if frames is None else sum(len(f.data) for f in frames)
        if send.drop_key is None and not self.replies.charge(nbytes) and not self.over_budget:
            self.over_budget = True
            self._over_budget(self.replies.reason())  # the edge closes the client
        victims = self.queue.push(send, nbytes, frames, self._outside_bytes())
        if victims:
            logger.debug(
                "client %d: dropped %d oldest of %s", self.client_id, len(victims), send.drop_key
            )

    def _service(self) -> None:
        """Write waiting messages while the socket has room, a fragment at a time."""
        blocked = False
        if self._big_out and self._has_room():  # the large frame of this turn has left
            self._end_turn()
        while self._has_room():
            waiting = self.queue.pop(self._busy)
            if waiting is None:
                break
            frames = waiting.frames
            if frames is None:
                self._start_render(waiting)
                continue
            piece = frames[waiting.first]
            if not self._fits(len(piece.data)):
                self.queue.push_front(waiting)
                blocked = True
                break
            if not self._may_write(waiting.send, piece):
                self.queue.push_front(waiting)
                self._waiting_turn_bytes = waiting.nbytes
                break
            if waiting.send.drop_key is None and not waiting.started:
                self.replies.credit(waiting.nbytes)  # answers are rendered when queued
            if waiting.first == len(frames) - 1:
                self._write(waiting.send, [piece], waiting.sent_bytes)
            else:
                self._write(waiting.send, [piece], final=False)
                self.queue.requeue(waiting, len(piece.data))
        if len(self.queue) and not self._corked and (blocked or not self._has_room()):
            self._wait_for_room()
        elif self._big_out and not self._corked:
            self._wait_for_room()  # (to end the turn once the frame has left)
        elif not self._big_out and self._turns.holds(self.client_id):
            self._end_turn()  # given a turn it had no large frame left to use
        self._note_progress()

    def _may_write(self, send: Send, frame: WireFrame) -> bool:
        """May `frame` go now? A large one only in this link's turn (`bridge.big_writes`)."""
        if len(frame.data) < BIG_BYTES:
            return True
        if not self._turns.take(self.client_id, self._turn_given):
            return False
        self._waiting_turn_bytes = 0
        self._big_out = True
        return True

    def _turn_given(self) -> None:
        self._waiting_turn_bytes = 0
        if self.closed:
            self._turns.release(self.client_id)
        else:
            self._service()

    def _end_turn(self) -> None:
        self._big_out = False
        self._turns.release(self.client_id)

    def _fits(self, nbytes: int) -> bool:
        """May a frame of `nbytes` go now? On a link measured thin (room below the maximum)
        only if it fits in the room or the socket has sent nearly everything (`SLACK_BYTES`:
        a trickle of small messages must not starve a large one): a fragment then waits for
        the one before it, and a small message behind it waits for one fragment at most."""
        if self.room_bytes >= self.max_room_bytes:
            return True
        outside = self._outside_bytes()
        return outside <= SLACK_BYTES or outside + nbytes <= self.room_bytes

    def _wait_for_room(self) -> None:
        """Look again when the link will have drained: the transport says when its own buffer
        is low; bytes the kernel holds, only a timer sized by the goodput can tell."""
        if self._transport.get_write_buffer_size() > self.max_room_bytes // 4:
            self._await_drain()
            return
        if self._pace_timer is not None or self.closed:
            return
        rate = self.goodput.rate_bytes_per_s
        delay_s = PACE_MAX_S / 4 if not rate else self._outside_bytes() / rate / 2
        self._pace_timer = self._loop.call_later(
            min(PACE_MAX_S, max(PACE_MIN_S, delay_s)), self._paced
        )

    def _paced(self) -> None:
        self._pace_timer = None
        if not self.closed:
            self._service()

    def _render(self, send: Send) -> list[WireFrame] | None:
        """The frames of `send`, or None (logged) if it cannot be encoded."""
        item = send.item
        try:
            if send.fragment_size is None and type(item) is Delivery and item.reduce is None:
                return [item.message.frame(item.encoding, item.topic)]  # the usual delivery
            frames = render(
                send.item, send.fragment_size, self._fragment_id(send), self._link_rate()
            )
        except Exception as exc:  # one unencodable message must not cost the client anything else
            self._encode_failed(send, exc)
            return None
        self._note_reduction(send, frames)
        return frames

    def _link_rate(self) -> float | None:
        return self.goodput.rate_bytes_per_s

    def _note_reduction(self, send: Send, frames: list[WireFrame]) -> None:
        if frames and frames[0].reduction is not None and send.drop_key is not None:
            self.reduced[send.drop_key] += 1

    def _start_render(self, waiting: Waiting) -> None:
        key = waiting.send.drop_key
        try:
            # (the fragment id is taken here, on the loop, so that ids stay unique)
            future = self._loop.run_in_executor(
                self._pool,
                render,
                waiting.send.item,
                waiting.send.fragment_size,
                self._fragment_id(waiting.send),
                self._link_rate(),
            )
        except RuntimeError:  # the pool has shut down: the server is stopping
            return
        self._busy.add(key)

        def rendered(done: asyncio.Future[list[WireFrame]]) -> None:
            self._busy.discard(key)
            if done.cancelled() or self.closed:
                return
            exc = done.exception()
            if exc is not None:
                self._encode_failed(waiting.send, exc)
                return
            frames = done.result()
            self._note_reduction(waiting.send, frames)
            waiting.frames = frames
            waiting.nbytes = sum(len(f.data) for f in frames)
            self.queue.push_front(waiting)
            self._service()

        future.add_done_callback(rendered)

    def _encode_failed(self, send: Send, exc: BaseException) -> None:
        """One line per unencodable message, at most `LINES_PER_WINDOW` per client every
        `WINDOW_S`; the rest are counted and summed up when the window ends."""
        now_ns = time.time_ns()
        summary = self._problems.expired_summary(now_ns, self.node, "unencodable messages")
        if summary is not None:
            logger.warning("%s", summary)
        full, deadline = self._problems.note(now_ns)
        if full:
            logger.error(
                "[%s] cannot encode a message for %s: %s",
                self.node,
                safe_text(send.drop_key or "a reply", 120),
                echo(exc),
            )
        if deadline is not None and not self.closed:
            self._summary_timer = self._loop.call_later(
                (deadline - now_ns) / NS_PER_S, self._log_summary
            )

    def _log_summary(self) -> None:
        self._summary_timer = None
        summary = self._problems.summary(self.node, time.time_ns(), "unencodable messages")
        if summary is not None:
            logger.warning("%s", summary)

    def _fragment_id(self, send: Send) -> str:
        """A new id for the fragments of `send` if it may be fragmented (else none is used)."""
        if send.fragment_size is None:
            return ""
        self._fragment_seq += 1
        return f"fragment:{self._fragment_seq}"

    def _write(
        self, send: Send, frames: list[WireFrame], prior_bytes: int = 0, final: bool = True
    ) -> None:
        """Frame `frames` into the websocket; the bytes leave when this loop turn ends. A
        delivery counts once its `final` frames are written, with the `prior_bytes` of its
        earlier fragments."""
        protocol = self._protocol
        if protocol.state is not State.OPEN:
            return
        nbytes = 0
        if self._own_framing and not protocol.expect_continuation_frame:
            writes = protocol.writes
            for frame in frames:
                data = frame.data
                size = len(data)
                header = frame_header(frame.text, size)
                if size < JOIN_LIMIT:
                    writes.append(header + data)
                else:  # the shared buffer itself, not a copy per subscriber
                    writes.append(header)
                    writes.append(data)
                nbytes += size
        else:
            for frame in frames:
                if frame.text:
                    protocol.send_text(frame.data)
                else:
                    protocol.send_binary(frame.data)
                nbytes += len(frame.data)
        self._corked += nbytes
        self.frames_sent += len(frames)
        if final and isinstance(send.item, Delivery):
            self._just_delivered.append((send.item, prior_bytes + nbytes))
        if not self._flush_pending:
            self._flush_pending = True
            self._loop.call_soon(self._flush)

    def _flush(self) -> None:
        """Hand this turn's frames to the transport, small ones joined into one write."""
        self._flush_pending = False
        self._corked = 0
        chunks = self._protocol.data_to_send()
        if self._protocol.state is State.OPEN and not self._transport.is_closing():
            self._write_chunks(chunks)  # (closing: the frames can no longer be delivered)
            self._unsent_read_at = float("-inf")  # the kernel took some: read it afresh
        now_ns = time.time_ns()
        for delivery, nbytes in self._just_delivered:
            self._delivered(self.client_id, delivery, nbytes, now_ns)
        self._just_delivered.clear()
        if len(self.queue) or self._big_out:
            self._service()
        else:
            self._note_progress()

    def _write_chunks(self, chunks: list[bytes]) -> None:
        batch: list[bytes] = []
        for chunk in chunks:
            if not chunk:  # end of stream: only websockets' own closing produces it
                continue
            self._handed += len(chunk)
            if len(chunk) >= JOIN_LIMIT:
                if batch:
                    self._transport.write(b"".join(batch))
                    batch = []
                self._transport.write(chunk)
            else:
                batch.append(chunk)
        if batch:
            self._transport.write(b"".join(batch) if len(batch) > 1 else batch[0])

    def _await_drain(self) -> None:
        if self._drain_task is None and not self.closed:
            self._drain_task = self._loop.create_task(self._drain())

    async def _drain(self) -> None:
        try:
            await self.ws.drain()
        except Exception:  # the connection is going; the reader notices and closes the link
            return
        finally:
            self._drain_task = None
        if not self.closed:
            self._service()  # (notes the progress, which wakes paused readers)

    def close(self) -> None:
        """The client left: forget what waits and wake anyone waiting for this link."""
        self.closed = True
        self.queue.clear()
        if self._drain_task is not None:
            self._drain_task.cancel()
        if self._summary_timer is not None:
            self._summary_timer.cancel()
        if self._pace_timer is not None:
            self._pace_timer.cancel()
        self._end_turn()
        self._log_summary()
        self._progress.set()

    # -- room and pacing ---------------------------------------------------------------------

    def _outside_bytes(self) -> int:
        """Bytes handed on but not sent: framed this turn, in the transport, in the kernel."""
        return self._transport.get_write_buffer_size() + self._corked + self._unsent_in_kernel()

    def _has_room(self) -> bool:
        return self._outside_bytes() <= self.room_bytes

    def _unsent_in_kernel(self) -> int:
        """The kernel's unsent bytes (at most a millisecond old); each fresh reading also
        feeds the goodput meter and resizes the room."""
        now_s = self._loop.time()
        if now_s - self._unsent_read_at < UNSENT_FRESH_S or self._fd is None:
            return self._kernel_unsent
        self._unsent_read_at = now_s
        try:
            raw = fcntl.ioctl(self._fd, SIOCOUTQNSD, b"\0\0\0\0")
        except OSError:  # not a TCP socket (a test's transport), or already closed
            self._fd = None
            self._kernel_unsent = 0
            return 0
        unsent: int = struct.unpack("i", raw)[0]
        self._kernel_unsent = unsent
        in_transport = self._transport.get_write_buffer_size()
        left = self._handed - in_transport - unsent
        self.goodput.observe(now_s, left, backed_up=unsent + in_transport > 0)
        room = self.goodput.bytes_in(ROOM_HORIZON_S, self.max_room_bytes)
        self.room_bytes = min(self.max_room_bytes, max(MIN_ROOM_BYTES, room))
        return unsent

    def health(self) -> LinkHealth:
        """Goodput, round trip, unsent bytes, room and conflation of this link."""
        return LinkHealth(
            self.goodput.rate_bytes_per_s,
            float(self.ws.latency),
            self._outside_bytes(),
            self.room_bytes,
            dict(self.queue.conflated),
            dict(self.reduced),
        )

    def backlog_bytes(self) -> int:
        """Bytes this client has not taken yet: in the transport, framed, or queued."""
        return self._outside_bytes() + self.queue.bytes

    def _accepted_bytes(self) -> int:
        """Bytes the kernel has taken from this link's transport so far."""
        return self._handed - self._transport.get_write_buffer_size()

    def _paced_bytes(self) -> int:
        """Queued bytes publishers wait for: not a large frame only waiting for its turn."""
        return self.queue.lossless_bytes - self._waiting_turn_bytes

    def _note_progress(self) -> None:
        self._progress.set()
        if self._paced_bytes() <= self.pause_bytes:
            self._backed_up_since = None
            self._stalled = False

    @property
    def gone(self) -> bool:
        """The client left, or its connection is closing (nothing more will drain)."""
        return self.closed or self.closing or self._transport.is_closing()

    def wants_pause(self) -> bool:
        """Should readers feeding this link wait for it before reading on?"""
        if self.gone or self._stalled or self._paced_bytes() <= self.pause_bytes:
            return False
        now = self._loop.time()
        if self._backed_up_since is None:
            self._backed_up_since = now
        elif now - self._backed_up_since >= SLOW_S:
            self._give_up(f"has been backed up for {SLOW_S:g} s")
            return False
        return True

    def _give_up(self, why: str) -> None:
        """Stop pacing publishers for this link until it has caught up; it drops instead."""
        self._stalled = True
        logger.info(
            "client %d %s: publishers no longer wait for it; past %d bytes it loses "
            "its oldest messages per topic",
            self.client_id,
            why,
            self.queue.limit_bytes,
        )

    async def drained(self) -> None:
        """Return once the queue is under `pause_bytes`, or the link has proved stalled or
        slow (it then drops instead of pacing anyone until it catches up)."""
        mark, since = self._accepted_bytes(), self._loop.time()
        while self.wants_pause():
            if not self._corked:
                self._await_drain()  # the transport tells when it is down to its low mark
            self._progress.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(POLL_S):
                    await self._progress.wait()
            accepted = self._accepted_bytes()
            if accepted != mark:
                mark, since = accepted, self._loop.time()
            elif self._loop.time() - since > STALL_S and not self._waiting_turn_bytes:
                self._give_up(f"took no byte for {STALL_S:g} s")

    async def answers_taken(self, limit: int) -> None:
        """Return once at most `limit` undroppable items wait (or the link closed)."""
        while self.queue.answers_waiting > limit and not self.gone:
            self._progress.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(POLL_S):
                    await self._progress.wait()
