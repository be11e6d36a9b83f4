"""Publish an MCAP recording into a bridge at its recorded timing (rate-scaled, looped).

Timing: message *i* is published ``(log_time_i - log_time_0) / rate`` after the start of the
pass, on the event loop's clock; ``--loop`` starts a new pass after the last message. The clock
is a :class:`~clients.recording.control.PlaybackClock` that anyone on the bridge may pause,
resume, speed up or seek through the player's control service (a Foxglove client does it with
its playback controls; :mod:`clients.recording.control`); the player publishes its state.

Stamps (``header.stamp``, in every nested header, e.g. each transform of a TFMessage), chosen
with ``stamps``:

- ``shift`` (default): every stamp moves by the same offset, the one that maps the pass's
  first ``log_time`` to the wall clock when the pass starts (at ``rate`` != 1 stamps are
  scaled about that point too). A stamp then still means *capture time*, on today's clock:
  the gap between a message's stamp and its publication is the one recorded, so latencies
  measured downstream (``riverbridge report --replay``) are from capture as in the live run.
- ``now``: every stamp becomes the wall-clock time of its publication; latencies then start
  at the player, without the recorded capture-to-bridge part.
- ``keep``: the recorded stamps, unchanged (consumers that key on stamps see the old times).

Decoding CDR into the canonical form (rosbags) runs on a worker thread ahead of the schedule;
a type the local registry does not know is registered from the recording's own definition.
Each topic has its own sender task, so a 5 MB scan being encoded and sent never delays the
IMU samples scheduled behind it; small topics go over the process's realtime connection and
large ones over the bulk connection (:mod:`clients.node.links`).
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from rosbags.typesys import get_types_from_msg
from rosbags.typesys.base import TypesysError

from clients.client import RosbridgeClient
from clients.node.links import node_links
from clients.recording import control
from clients.recording.control import PlaybackClock
from clients.recording.reading import RecordedMessage, read_recording, recording_window
from clients.recording.topics import BRIDGE_OWNED, TopicFilter
from schemas.catalogue import published_by
from schemas.codec_cdr import from_cdr
from schemas.errors import SchemaError
from schemas.interface_files import InterfaceSet
from schemas.registry import TypeRegistry

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
StampMode = Literal["shift", "now", "keep"]
STAMP_MODES: tuple[StampMode, ...] = ("shift", "now", "keep")
# Messages decoded ahead of their time: a few seconds of the full stack, a handful of scans.
LOOKAHEAD = 256
BATCH = 16  # messages decoded per worker-thread hop
BULK_BYTES = 64 * 1024  # from this size a topic goes over the bulk connection
# Topics the simulator latches (schemas.catalogue); replayed latched too.
LATCHED = tuple(t.name for t in published_by("simulator") if t.latched)


@dataclass
class PlayStats:
    """What a replay did: messages per topic, passes, how late publishing ran."""

    passes: int = 0
    messages: dict[str, int] = field(default_factory=dict)
    max_late_s: float = 0.0
    skipped_topics: dict[str, str] = field(default_factory=dict)

    @property
    def total(self) -> int:
        return sum(self.messages.values())


@dataclass(frozen=True, slots=True)
class Scheduled:
    """A decoded message and when (offset in the pass, s) it is due."""

    topic: str
    type_name: str
    msg: dict[str, Any]
    log_ns: int  # its recorded log time, which the clock says when to publish
    size: int


def restamp(msg: Any, change: Callable[[int], int]) -> None:
    """Apply ``change`` (ns -> ns) to every ``header.stamp`` in ``msg``, in place.

    Walks nested messages and lists of messages, never numeric arrays."""
    if isinstance(msg, dict):
        header = msg.get("header")
        if isinstance(header, dict) and isinstance(header.get("stamp"), dict):
            stamp = header["stamp"]
            sec, nanosec = divmod(
                change(int(stamp["sec"]) * NS_PER_S + int(stamp["nanosec"])), NS_PER_S
            )
            header["stamp"] = {"sec": sec, "nanosec": nanosec}
        for value in msg.values():
            if isinstance(value, dict | list):
                restamp(value, change)
    elif isinstance(msg, list) and msg and isinstance(msg[0], dict):
        for item in msg:
            restamp(item, change)


def ensure_type(registry: TypeRegistry, type_name: str, definition: str) -> None:
    """Register ``type_name`` from its full ``ros2msg`` text unless it is already known.

    Raises :class:`SchemaError` when the text does not parse or clashes with known types."""
    if registry.has_message(type_name):
        return
    try:
        types = get_types_from_msg(definition, type_name)
    except TypesysError as exc:
        raise SchemaError(
            f"the recording's definition of {type_name} does not parse: {exc}"
        ) from None
    registry.add_interfaces(InterfaceSet(types=types))


class Player:
    """Publishes the recording at ``path`` into the bridge at ``url``."""

    def __init__(
        self,
        url: str,
        path: Path,
        *,
        topics: TopicFilter | None = None,
        rate: float = 1.0,
        loop: bool = False,
        stamps: StampMode = "shift",
        registry: TypeRegistry | None = None,
        connect_timeout_s: float = 10.0,
        stay: bool = False,
    ) -> None:
        if not rate > 0:
            raise ValueError(f"rate must be positive, got {rate}")
        self.url, self.path, self.rate, self.loop, self.stamps = url, path, rate, loop, stamps
        self.stay = stay  # after the end, wait (paused at the end) for a seek or a stop
        self.topics = topics or TopicFilter(excluded=BRIDGE_OWNED)
        self.registry = registry or TypeRegistry.with_defaults()
        self.stats = PlayStats()
        self._connect_timeout_s = connect_timeout_s
        self._senders: dict[str, tuple[asyncio.Queue[Scheduled | None], asyncio.Task[None]]] = {}
        self.window_ns = (0, 0)  # the recording's first and last log time
        self.clock = PlaybackClock(rate, 0, 0.0, 0)
        self.ended = False
        self._seek_ns: int | None = None  # a seek waiting for the pass to end
        self._changed = asyncio.Event()  # the clock was paused, resumed, sped up or seeked
        self._state_client: RosbridgeClient | None = None

    async def run(self, stop: asyncio.Event) -> PlayStats:
        """Play until the recording ends (or ``stop``; with ``loop`` or ``stay``, only
        ``stop``)."""
        self.window_ns = await asyncio.to_thread(recording_window, self.path, self.topics)
        self.clock.rebase(self.window_ns[0], asyncio.get_running_loop().time(), time.time_ns())
        async with node_links(
            self.url, "player", connect_timeout_s=self._connect_timeout_s
        ) as links:
            states = await self._offer_control(links.realtime)
            try:
                await self._passes(stop, links.bulk, links.realtime)
                await self._drain_senders()
            finally:
                states.cancel()
                await asyncio.gather(states, return_exceptions=True)
                for _, task in self._senders.values():
                    task.cancel()
                await asyncio.gather(
                    *(t for _, t in self._senders.values()), return_exceptions=True
                )
        return self.stats

    async def _passes(
        self, stop: asyncio.Event, bulk: RosbridgeClient, realtime: RosbridgeClient
    ) -> None:
        """Passes over the recording: again after the end with ``loop``, from the new place
        after a seek; with ``stay``, wait at the end for a seek."""
        start_ns = self.window_ns[0]
        while not stop.is_set():
            self.ended = False
            played = await self._one_pass(stop, bulk, realtime, start_ns)
            if self._seek_ns is not None:
                start_ns, self._seek_ns = self._seek_ns, None
                continue
            self.stats.passes += 1
            start_ns = self.window_ns[0]
            if self.loop and played:
                continue
            if not self.stay:
                break
            self.ended = True
            self.clock.pause(asyncio.get_running_loop().time(), time.time_ns())
            self.clock.log_ns = self.window_ns[1]
            await self._publish_state()
            while self._seek_ns is None and not stop.is_set():
                await self._wait_change(stop, None)
            if self._seek_ns is not None:
                start_ns, self._seek_ns = self._seek_ns, None

    async def _one_pass(
        self,
        stop: asyncio.Event,
        bulk: RosbridgeClient,
        realtime: RosbridgeClient,
        start_ns: int,
    ) -> int:
        """Publish the recording once from log time `start_ns`; the number of messages
        published. Ends early for a seek.

        The clock starts once the first ``LOOKAHEAD`` messages are decoded and their topics
        advertised, so neither delays the first messages."""
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[Scheduled | None] = asyncio.Queue(LOOKAHEAD)
        reader = asyncio.create_task(self._decode_into(queue, start_ns))
        played = 0
        try:
            ahead = await self._prefetch(queue)
            for item in ahead:
                if item is not None:
                    await self._sender(item, bulk, realtime)
            self.clock.rebase(start_ns, loop.time(), time.time_ns())
            while (item := ahead.popleft() if ahead else await queue.get()) is not None:
                late_s = await self._until_due(item, stop)
                if stop.is_set() or self._seek_ns is not None:
                    break
                self.stats.max_late_s = max(self.stats.max_late_s, late_s)
                if self.stamps == "shift":
                    restamp(item.msg, self.clock.shifted)
                (await self._sender(item, bulk, realtime)).put_nowait(item)
                played += 1
        finally:
            reader.cancel()
            await asyncio.gather(reader, return_exceptions=True)
        return played

    async def _until_due(self, item: Scheduled, stop: asyncio.Event) -> float:
        """Wait until the clock reaches `item` (paused: until resumed); how late it is."""
        loop = asyncio.get_running_loop()
        while not stop.is_set() and self._seek_ns is None:
            delay_s = self.clock.delay_s(item.log_ns, loop.time())
            if delay_s is not None and delay_s <= 0:
                return -delay_s
            await self._wait_change(stop, delay_s)
        return 0.0

    async def _wait_change(self, stop: asyncio.Event, timeout_s: float | None) -> None:
        """Wait for `timeout_s` (None: without end), a control request or `stop`."""
        self._changed.clear()
        waits = [asyncio.ensure_future(stop.wait()), asyncio.ensure_future(self._changed.wait())]
        try:
            await asyncio.wait(waits, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for waiting in waits:
                waiting.cancel()

    # -- control ------------------------------------------------------------------------------

    async def _offer_control(self, client: RosbridgeClient) -> asyncio.Task[None]:
        """Advertise the control service and the state topic; the task publishing the state."""
        self._state_client = client
        await client.advertise(control.STATE_TOPIC, control.STATE_TYPE)
        await client.advertise_service(control.CONTROL_SERVICE, control.CONTROL_TYPE, self._control)
        return asyncio.create_task(self._publish_states(), name="playback state")

    async def _control(self, request: dict[str, Any]) -> dict[str, Any]:
        """A PlaybackControl request: seek, speed, then play or pause; the state after it."""
        now_s, wall_ns = asyncio.get_running_loop().time(), time.time_ns()
        did_seek = bool(request.get("seek"))
        if did_seek:
            first, last = self.window_ns
            target = min(max(control.stamp_ns(request.get("seek_time")), first), last)
            self._seek_ns = target
            self.clock.hold(target, now_s, wall_ns)  # until the pass has read ahead from there
            self.ended = False
        self.clock.set_speed(float(request.get("speed") or 0.0), now_s, wall_ns)
        if request.get("play", True):
            self.clock.play(now_s, wall_ns)
        else:
            self.clock.pause(now_s, wall_ns)
        self._changed.set()
        log.info("playback control: %s", self._state_text())
        await self._publish_state()
        state = self.state()
        asked = control.PLAYING if self.clock.playing else control.PAUSED
        return {
            "status": control.ENDED if self.ended else asked,
            "current_time": state["current_time"],
            "speed": state["speed"],
            "did_seek": did_seek,
        }

    def state(self) -> dict[str, Any]:
        """The PlaybackState message now."""
        first, last = self.window_ns
        position = self.clock.position_ns(asyncio.get_running_loop().time())
        if self.ended:
            status = control.ENDED
        elif self.clock.held and self.clock.playing:
            status = control.BUFFERING
        else:
            status = control.PLAYING if self.clock.playing else control.PAUSED
        return {
            "status": status,
            "current_time": control.stamp(min(max(position, first), last)),
            "speed": self.clock.speed,
            "start_time": control.stamp(first),
            "end_time": control.stamp(last),
        }

    def _state_text(self) -> str:
        state = self.state()
        at_s = (control.stamp_ns(state["current_time"]) - self.window_ns[0]) / control.NS_PER_S
        return f"status {state['status']} at {at_s:.3f} s, speed {state['speed']:g}"

    async def _publish_state(self) -> None:
        if self._state_client is not None:
            await self._state_client.publish(control.STATE_TOPIC, self.state())

    async def _publish_states(self) -> None:
        while True:
            await self._publish_state()
            await asyncio.sleep(control.STATE_PERIOD_S)

    @staticmethod
    async def _prefetch(queue: asyncio.Queue[Scheduled | None]) -> deque[Scheduled | None]:
        """The first ``LOOKAHEAD`` items (fewer if the recording ends first)."""
        ahead: deque[Scheduled | None] = deque()
        while len(ahead) < LOOKAHEAD and (not ahead or ahead[-1] is not None):
            ahead.append(await queue.get())
        return ahead

    async def _decode_into(self, queue: asyncio.Queue[Scheduled | None], start_ns: int) -> None:
        """Read and decode on a worker thread, ``BATCH`` messages per hop, into ``queue``."""
        messages = read_recording(self.path, self.topics, start_ns)
        try:
            while batch := await asyncio.to_thread(self._decode_batch, messages):
                for item in batch:
                    await queue.put(item)
        finally:
            messages.close()
        await queue.put(None)

    def _decode_batch(self, messages: Iterator[RecordedMessage]) -> list[Scheduled]:
        batch: list[Scheduled] = []
        for recorded in messages:
            item = self._decode(recorded)
            if item is not None:
                batch.append(item)
            if len(batch) >= BATCH:
                break
        return batch

    def _decode(self, recorded: RecordedMessage) -> Scheduled | None:
        topic = recorded.topic
        if topic in self.stats.skipped_topics:
            return None
        try:
            ensure_type(self.registry, recorded.type_name, recorded.definition)
            msg = from_cdr(self.registry, recorded.type_name, recorded.cdr)
        except SchemaError as exc:
            self.stats.skipped_topics[topic] = str(exc)
            log.warning("not playing %s (%s): %s", topic, recorded.type_name, exc)
            return None
        return Scheduled(topic, recorded.type_name, msg, recorded.log_time_ns, len(recorded.cdr))

    async def _sender(
        self, item: Scheduled, bulk: RosbridgeClient, realtime: RosbridgeClient
    ) -> asyncio.Queue[Scheduled | None]:
        """The queue of ``item``'s topic; the first time, advertise it and start its sender."""
        entry = self._senders.get(item.topic)
        if entry is None:
            client = bulk if item.size >= BULK_BYTES else realtime
            await client.advertise(item.topic, item.type_name, latch=item.topic in LATCHED)
            log.info("playing %s (%s)", item.topic, item.type_name)
            queue: asyncio.Queue[Scheduled | None] = asyncio.Queue()
            task = asyncio.create_task(
                self._send(client, item.topic, queue), name=f"play {item.topic}"
            )
            entry = self._senders[item.topic] = (queue, task)
        return entry[0]

    async def _send(
        self, client: RosbridgeClient, topic: str, queue: asyncio.Queue[Scheduled | None]
    ) -> None:
        """Publish what arrives on ``queue`` in order (None ends)."""
        while (item := await queue.get()) is not None:
            if self.stamps == "now":
                restamp(item.msg, functools.partial(_constant, time.time_ns()))
            await client.publish(topic, item.msg)
            self.stats.messages[topic] = self.stats.messages.get(topic, 0) + 1

    async def _drain_senders(self) -> None:
        """Let every topic's sender publish what is queued, then end it."""
        for queue, _ in self._senders.values():
            queue.put_nowait(None)
        await asyncio.gather(*(task for _, task in self._senders.values()), return_exceptions=True)


def _constant(value: int, _ignored: int) -> int:
    return value
