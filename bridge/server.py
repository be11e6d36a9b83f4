"""The asyncio edge: sockets, clock, timers, per-client writers and shutdown.

Everything protocol-related happens in `BridgeCore`; this module only pumps frames into it,
carries out the effects it returns, and keeps slow work off the event loop: frames and
encodes above `offload_threshold_bytes` run in a small thread pool, and each client has a
writer task draining a bounded `SendQueue`, so a slow reader backs up only itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import AsyncIterator, Callable, Hashable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from bridge.access import HandshakePolicy, scheme, tls_context
from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.effects import Close, Effect, Schedule, Send
from bridge.http import HttpRoutes
from bridge.outgoing import Delivery, WireFrame, render
from bridge.reply_budget import POLICY_VIOLATION, ReplyBudget
from bridge.sendqueue import SendQueue
from bridge.stats import BridgeTelemetry
from bridge.webapp import default_web_root, mount_webapp
from schemas.errors import SchemaError
from schemas.registry import TypeRegistry

logger = logging.getLogger("bridge.server")

# Bytes the transport may buffer per client before `send` waits: a few small frames, or one
# slice of a scan, without letting a stalled reader pin many megabytes.
WRITE_HIGH_WATER = 1024 * 1024
ENCODE_WORKERS = 2  # the machine has 2 cores; more threads only contend for the GIL
# A client that stopped reading cannot finish a closing handshake; do not wait long for it.
CLOSE_TIMEOUT_S = 3.0
# Undroppable frames (service answers, forwarded requests) a client may leave unread before
# the bridge stops reading its requests: a client that calls without reading then waits on
# TCP instead of growing the bridge's memory.
ANSWER_BACKLOG = 256
TRY_AGAIN_LATER = 1013  # RFC 6455: a handshake that raced past --max-clients


class ClientLink:
    """The edge's half of one connection: websocket, send queue and writer task."""

    def __init__(self, client_id: int, ws: ServerConnection, limit: int,
                 reply_budget_bytes: int) -> None:
        self.client_id = client_id
        self.ws = ws
        self.queue = SendQueue(limit)
        self.replies = ReplyBudget(reply_budget_bytes)  # unread undroppable bytes
        self.ready = asyncio.Event()
        self.room = asyncio.Event()  # set while answers_waiting <= ANSWER_BACKLOG
        self.room.set()
        self.writer: asyncio.Task[None] | None = None
        self.frames_sent = 0
        self.over_budget = False

    def enqueue(self, send: Send) -> bool:
        """Queue `send`; False when an answer takes the client past its reply budget."""
        within = send.drop_key is None and self.replies.charge(reply_bytes(send))
        if self.queue.push(send) is not None:
            logger.debug("client %d: dropped oldest message of %s", self.client_id,
                         send.drop_key)
        self.ready.set()
        return within or send.drop_key is not None


def reply_bytes(send: Send) -> int:
    """Wire bytes of an undroppable item (its frame is encoded once and kept)."""
    try:
        return len(send.item.frame().data)
    except SchemaError:
        return 0  # cannot be sent at all; the writer logs it


class BridgeServer:
    """Owns the websocket server and feeds `core`; start with `start()`, end with `stop()`."""

    def __init__(self, config: BridgeConfig, core: BridgeCore) -> None:
        self.config = config
        self.core = core
        self.links: dict[int, ClientLink] = {}
        self._timers: dict[Hashable, asyncio.TimerHandle] = {}
        self._pool = ThreadPoolExecutor(ENCODE_WORKERS, thread_name_prefix="bridge-encode")
        self._server: Server | None = None
        self._closing: set[asyncio.Task[None]] = set()
        self.http = HttpRoutes()  # plain HTTP on the websocket port; others add routes
        self.access = HandshakePolicy(config)  # Origin and client-limit checks (bridge.access)
        mount_webapp(self.http, config.web_root or default_web_root())
        self.telemetry = BridgeTelemetry(self)  # spans, stats service, /metrics
        self._telemetry_task: asyncio.Task[None] | None = None
        # In-process clients (a DDS mirror's stand-ins): client id -> who takes their sends.
        self.internal_clients: dict[int, Callable[[Send], None]] = {}

    @property
    def port(self) -> int:
        assert self._server is not None, "server not started"
        return self._server.sockets[0].getsockname()[1]

    async def start(self) -> None:
        self._server = await serve(
            self._handle, self.config.host, self.config.port,
            compression=None, max_size=self.config.max_message_size,
            write_limit=WRITE_HIGH_WATER, close_timeout=CLOSE_TIMEOUT_S,
            process_request=self._process_request, ssl=tls_context(self.config),
        )
        self._telemetry_task = asyncio.create_task(self.telemetry.run(self.apply),
                                                   name="bridge-telemetry")

    async def stop(self) -> None:
        """Close every connection (1001), stop timers and workers."""
        if self._telemetry_task is not None:
            self._telemetry_task.cancel()
        if self._server is not None:
            self._server.close()
            try:
                async with asyncio.timeout(CLOSE_TIMEOUT_S):
                    await self._server.wait_closed()
            except TimeoutError:
                # A peer that stopped reading leaves the close frame stuck behind a full
                # socket buffer; websockets would wait for its ping timeout. Cut it off.
                for link in list(self.links.values()):
                    link.ws.transport.abort()
                await self._server.wait_closed()
        for timer in self._timers.values():
            timer.cancel()
        self._timers.clear()
        self._pool.shutdown(wait=False, cancel_futures=True)

    def _process_request(self, connection: ServerConnection, request: Request) -> Response | None:
        """Refuse handshakes `bridge.access` rejects (403, 503); plain HTTP goes to the routes."""
        if "websocket" in request.headers.get("Upgrade", "").lower():
            refusal = self.access.refusal(request, len(self.links))
            if refusal is not None:
                logger.warning("refused a websocket handshake from %s: %s",
                               connection.remote_address, refusal[1].strip())
                return connection.respond(*refusal)
        return self.http(connection, request)

    # -- one connection ----------------------------------------------------------------------

    async def _handle(self, ws: ServerConnection) -> None:
        if self.config.max_clients is not None and len(self.links) >= self.config.max_clients:
            await ws.close(TRY_AGAIN_LATER, "too many clients")
            return
        peer = "{}:{}".format(*ws.remote_address[:2]) if ws.remote_address else ""
        client_id = self.core.connect(peer)
        link = self.links[client_id] = ClientLink(client_id, ws, self.config.send_queue,
                                                  self.config.reply_budget_bytes)
        link.writer = asyncio.create_task(self._write(link), name=f"bridge-writer-{client_id}")
        self.apply(self.telemetry.clients_changed())
        try:
            async for data in ws:
                self.apply(await self._receive(client_id, data))
                while link.queue.answers_waiting > ANSWER_BACKLOG and not link.writer.done():
                    link.room.clear()
                    await link.room.wait()
        except ConnectionClosed as exc:
            logger.info("client %d closed: %s", client_id, exc)
        finally:
            del self.links[client_id]
            link.writer.cancel()
            self.apply(self.core.disconnect(client_id, time.time_ns()))
            self.apply(self.telemetry.clients_changed())
            with contextlib.suppress(asyncio.CancelledError):
                await link.writer

    async def _receive(self, client_id: int, data: bytes | str) -> list[Effect]:
        arrived_ns = time.time_ns()
        if len(data) < self.config.offload_threshold_bytes:
            self.telemetry.tracer.frame_arrived(arrived_ns, len(data))
            return self.core.receive(client_id, data, arrived_ns)
        loop = asyncio.get_running_loop()
        try:
            decoded = await loop.run_in_executor(self._pool, self.core.prepare, data,
                                                 time.time_ns())
        except SchemaError as exc:
            return self.core.receive_invalid(client_id, str(exc), time.time_ns())
        self.telemetry.tracer.frame_arrived(arrived_ns, len(data))
        return self.core.receive_decoded(client_id, decoded, time.time_ns())

    async def _write(self, link: ClientLink) -> None:
        try:
            await self._write_until_closed(link)
        finally:
            link.room.set()  # the reader must not wait for a writer that has stopped

    async def _write_until_closed(self, link: ClientLink) -> None:
        sequence = 0  # numbers fragment ids of messages that have no id of their own
        while True:
            send = link.queue.pop()
            if link.queue.answers_waiting <= ANSWER_BACKLOG:
                link.room.set()
            if send is None:
                link.ready.clear()
                await link.ready.wait()
                continue
            sequence += 1
            frames = await self._render(send, f"fragment:{sequence}")
            handed_ns = time.time_ns()
            try:
                for frame in frames:
                    handed_ns = time.time_ns()  # websockets writes it to the transport now
                    await link.ws.send(frame.data, text=frame.text)
                    link.frames_sent += 1
            except ConnectionClosed:
                return
            if send.drop_key is None:
                link.replies.credit(reply_bytes(send))
            if isinstance(send.item, Delivery):
                self.telemetry.tracer.delivered(link.client_id, send.item,
                                                sum(len(f.data) for f in frames), handed_ns)

    async def _render(self, send: Send, fallback_id: str) -> list[WireFrame]:
        try:
            if send.item.size_hint < self.config.offload_threshold_bytes:
                return render(send.item, send.fragment_size, fallback_id)
            loop = asyncio.get_running_loop()
            return await loop.run_in_executor(self._pool, render, send.item,
                                              send.fragment_size, fallback_id)
        except Exception:  # one unencodable message must not end the client's writer
            logger.exception("client %d: cannot encode a message for %s", send.client_id,
                             send.drop_key or "a reply")
            return []

    # -- effects -----------------------------------------------------------------------------

    def apply(self, effects: list[Effect]) -> None:
        for effect in effects:
            if isinstance(effect, Send):
                link = self.links.get(effect.client_id)
                if link is not None:
                    if not link.enqueue(effect) and not link.over_budget:
                        link.over_budget = True
                        logger.warning("client %d: closing, %s", link.client_id,
                                       link.replies.reason())
                        self.apply([Close(link.client_id, POLICY_VIOLATION,
                                          link.replies.reason())])
                elif effect.client_id in self.internal_clients:
                    self.internal_clients[effect.client_id](effect)
            elif isinstance(effect, Schedule):
                self._schedule(effect.key, effect.at_ns)
            elif isinstance(effect, Close):
                link = self.links.get(effect.client_id)
                if link is not None:
                    task = asyncio.get_running_loop().create_task(
                        link.ws.close(effect.code, effect.reason))
                    self._closing.add(task)
                    task.add_done_callback(self._closing.discard)

    def _schedule(self, key: Hashable, at_ns: int) -> None:
        previous = self._timers.pop(key, None)
        if previous is not None:
            previous.cancel()
        delay_s = max(0.0, (at_ns - time.time_ns()) / 1e9)
        self._timers[key] = asyncio.get_running_loop().call_later(delay_s, self._fire, key)

    def _fire(self, key: Hashable) -> None:
        self._timers.pop(key, None)
        self.apply(self.core.on_deadline(key, time.time_ns()))

    def stats(self) -> dict[int, dict[str, object]]:
        """Per connected client: frames sent, messages dropped per topic, items waiting."""
        return {cid: {"frames_sent": link.frames_sent, "dropped": dict(link.queue.dropped),
                      "waiting": len(link.queue)} for cid, link in self.links.items()}


@dataclass(frozen=True)
class RunningBridge:
    """A started bridge: where it listens, and its parts for tests and tools."""

    host: str
    port: int
    server: BridgeServer
    dds: Any = None  # the DDS mirror (bridge.dds.mirror.DdsMirror) when config.dds

    @property
    def url(self) -> str:
        return f"{scheme(self.server.config)}://{self.host}:{self.port}"

    @property
    def core(self) -> BridgeCore:
        return self.server.core


@contextlib.asynccontextmanager
async def run_bridge(config: BridgeConfig,
                     registry: TypeRegistry | None = None) -> AsyncIterator[RunningBridge]:
    """Start a bridge for the duration of the `async with` block.

    `registry` defaults to the standard types plus `config.interface_dirs`.
    """
    if registry is None:
        registry = TypeRegistry.with_defaults(config.interface_dirs)
    server = BridgeServer(config, BridgeCore(config, registry))
    await server.start()
    mirror = None
    try:
        if config.dds:  # imported only when asked: Cyclone DDS loads a C library
            from bridge.dds.mirror import DdsMirror
            joining = DdsMirror(server)
            await joining.start()
            mirror = joining
        yield RunningBridge(config.host, server.port, server, mirror)
    finally:
        if mirror is not None:
            await mirror.stop()
        await server.stop()


__all__ = ["BridgeServer", "RunningBridge", "run_bridge"]


