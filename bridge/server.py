"""The asyncio edge: sockets, clock, timers, per-client links and shutdown.

Everything protocol-related happens in `BridgeCore`; this module only pumps frames into it and
carries out the effects it returns. Each connection has an `Intake` (inbound: big frames decoded
on a worker, order kept per topic) and a `ClientLink` (outbound: write-through while the socket
has room, a byte-bounded backlog when it has not). Messages come straight from websockets'
parser (`bridge.reading`, no `recv()` task per frame). Readers take fair turns: after
`TURN_S` of handling one chunk a reader pauses, so the frames it produced go out and other
clients get read; a reader also waits while the clients its messages go to are backed up (TCP
backpressure on the publisher), and while its own client leaves too many answers unread.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.http11 import Request, Response
from websockets.typing import Subprotocol

from bridge.access import HandshakePolicy, handshake_token, tls_context
from bridge.big_writes import BigWriteTurns
from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.effects import Close, DeadlineKey, Effect, Hold, Schedule, Send
from bridge.goodput import LinkHealth
from bridge.http import HttpRoutes
from bridge.intake import Intake
from bridge.link import WRITE_HIGH_WATER, ClientLink, Delivered
from bridge.outgoing import Delivery
from bridge.reading import FrameConnection, Reader, read_until_closed
from bridge.reply_budget import POLICY_VIOLATION

if TYPE_CHECKING:
    from bridge.host import ProtocolConnection, ProtocolFactory

logger = logging.getLogger("bridge.server")

ENCODE_WORKERS = 2  # the machine has 2 cores; more threads only contend for the GIL
# A client that stopped reading cannot finish a closing handshake; do not wait long for it.
CLOSE_TIMEOUT_S = 3.0
# Undroppable frames (service answers, forwarded requests) a client may leave unread before
# the bridge stops reading its requests: a client that calls without reading then waits on
# TCP instead of growing the bridge's memory.
ANSWER_BACKLOG = 256
# Frames of one connection taken but not yet handled (decoding on a worker, or waiting behind
# one) before the bridge stops reading that connection.
INTAKE_FRAMES = 256
INTAKE_BYTES = 32 * 1024 * 1024
TRY_AGAIN_LATER = 1013  # RFC 6455: a handshake that raced past --max-clients


def no_observer(client_id: int, delivery: Delivery, wire_bytes: int, written_ns: int) -> None:
    """The default `BridgeServer.delivered`: nobody counts deliveries."""


class BridgeServer:
    """Owns the websocket server and feeds `core`; start with `start()`, end with `stop()`.

    Plug-ins never see it: `bridge.compose` wraps it in a `PluginHost` (`bridge.host.Edge` is
    what the host uses of it: `http`, `internal_clients`, `delivered`, `clients_changed`).
    """

    def __init__(self, config: BridgeConfig, core: BridgeCore) -> None:
        self.config = config
        self.core = core
        self.links: dict[int, ClientLink] = {}
        self._timers: dict[DeadlineKey, asyncio.TimerHandle] = {}
        self._pool = ThreadPoolExecutor(ENCODE_WORKERS, thread_name_prefix="bridge-encode")
        self._server: Server | None = None
        self._closing: set[asyncio.Task[None]] = set()
        self.http = HttpRoutes()  # plain HTTP on the websocket port; others add routes
        self.access = HandshakePolicy(config)  # Origin and client-limit checks (bridge.access)
        # In-process clients (a DDS mirror's stand-ins): client id -> who takes their sends.
        self.internal_clients: dict[int, Callable[[Send], None]] = {}
        self.delivered: Delivered = no_observer  # told when a delivery's frames are written
        self.clients_changed: list[Callable[[], None]] = []  # after a client comes or goes
        self._holds: dict[int, int] = {}  # client id -> read nothing of it before (ns)
        self._big_writes = BigWriteTurns()  # large frames fanned out take turns

        # Other protocols by websocket subprotocol (Foxglove's); a client offering none of
        # them speaks rosbridge v2. Their connections translate what the core sends them.
        self.protocols: dict[str, ProtocolFactory] = {}
        self._translators: dict[int, Callable[[Send], list[Send]]] = {}
        # While another protocol's client's frame is handled: the links its messages went to
        # that ask its reader to wait (its ops reach the core through the plug-in host).
        self._pacing: set[ClientLink] | None = None

    @property
    def port(self) -> int:
        assert self._server is not None, "server not started"
        port: int = self._server.sockets[0].getsockname()[1]
        return port

    async def start(self) -> None:
        self._server = await serve(
            self._handle,
            self.config.host,
            self.config.port,
            compression=None,
            max_size=self.config.max_message_size,
            write_limit=WRITE_HIGH_WATER,
            close_timeout=CLOSE_TIMEOUT_S,
            process_request=self._process_request,
            select_subprotocol=self._select_subprotocol,
            create_connection=FrameConnection,
            ssl=tls_context(self.config),
        )

    async def stop(self) -> None:
        """Close every connection (1001), stop timers and workers."""
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
                logger.warning(
                    "refused a websocket handshake from %s: %s",
                    connection.remote_address,
                    refusal[1].strip(),
                )
                return connection.respond(*refusal)
        return self.http(connection, request)

    def _select_subprotocol(
        self, connection: ServerConnection, offered: Sequence[Subprotocol]
    ) -> Subprotocol | None:
        """The first offered subprotocol a plug-in speaks; None (rosbridge v2) otherwise."""
        return next((name for name in offered if name in self.protocols), None)

    # -- one connection ----------------------------------------------------------------------

    async def _handle(self, ws: ServerConnection) -> None:
        assert isinstance(ws, FrameConnection)  # (serve's create_connection)
        if self.config.max_clients is not None and len(self.links) >= self.config.max_clients:
            await ws.close(TRY_AGAIN_LATER, "too many clients")
            return
        peer = "{}:{}".format(*ws.remote_address[:2]) if ws.remote_address else ""
        client_id = self.core.connect(peer)
        link = self.links[client_id] = ClientLink(
            client_id,
            ws,
            limit_bytes=self.config.send_buffer_bytes,
            pool=self._pool,
            offload_bytes=self.config.offload_threshold_bytes,
            reply_budget_bytes=self.config.reply_budget_bytes,
            delivered=self.delivered,
            over_budget=lambda reason: self._close_over_budget(client_id, reason),
            node=self.core.state.sessions[client_id].node,
            turns=self._big_writes,
        )
        paced: set[ClientLink] = set()  # links this client's messages went to that are full

        def apply(effects: list[Effect]) -> None:
            self.apply(effects, paced)

        intake = Intake(client_id, self.core, self._pool, apply)
        factory = self.protocols.get(ws.subprotocol) if ws.subprotocol else None
        other = factory(client_id, ws.subprotocol or "") if factory is not None else None
        if other is not None:
            self._translators[client_id] = other.outgoing
        self._tell_clients_changed()
        token = handshake_token(ws.request) if ws.request is not None else None
        self.apply(self.core.admit(client_id, time.time_ns(), token))
        reader = self._reader(ws, intake, other, link, paced, client_id)
        try:
            await read_until_closed(reader, ws)
            logger.info("client %d closed: %s %s", client_id, ws.close_code, ws.close_reason)
        finally:
            intake.closed = True
            if other is not None:
                other.close()
                del self._translators[client_id]
            del self.links[client_id]
            self._holds.pop(client_id, None)
            link.close()
            self.apply(self.core.disconnect(client_id, time.time_ns()))
            self._tell_clients_changed()

    def _reader(
        self,
        ws: FrameConnection,
        intake: Intake,
        other: ProtocolConnection | None,
        link: ClientLink,
        paced: set[ClientLink],
        client_id: int,
    ) -> Reader:
        """The connection's reader: frames to the intake (or to another protocol's connection,
        with the links its messages went to collected in `paced`), with fair turns, pacing by
        backed-up subscribers, a wait while the client leaves answers unread, and holds."""
        if other is None:

            def handle(data: str | bytes) -> None:
                intake.take(data, time.time_ns())

            def must_wait() -> bool:
                return bool(
                    paced
                    or intake.in_flight > INTAKE_FRAMES
                    or intake.pending_bytes > INTAKE_BYTES
                    or link.queue.answers_waiting > ANSWER_BACKLOG
                    or client_id in self._holds
                )

        else:
            receive = other.receive

            def handle(data: str | bytes) -> None:
                self._pacing = paced
                try:
                    receive(data)
                finally:
                    self._pacing = None

            def must_wait() -> bool:
                return bool(
                    paced or link.queue.answers_waiting > ANSWER_BACKLOG or client_id in self._holds
                )

        async def wait() -> None:
            while paced:
                await paced.pop().drained()
            await link.answers_taken(ANSWER_BACKLOG)
            if other is None:
                await intake.settled(INTAKE_FRAMES // 2, INTAKE_BYTES // 2)
            await self._held(client_id)

        return Reader(ws, handle, must_wait, wait)

    async def _held(self, client_id: int) -> None:
        """A client past its quota (`Hold`): wait until it has room, reading nothing of it."""
        until_ns = self._holds.pop(client_id, None)
        if until_ns is not None:
            await asyncio.sleep(max(0.0, (until_ns - time.time_ns()) / 1e9))

    def _tell_clients_changed(self) -> None:
        for callback in self.clients_changed:
            callback()

    def _close_over_budget(self, client_id: int, reason: str) -> None:
        """A client left more answers unread than its reply budget (`bridge.reply_budget`)."""
        logger.warning("client %d: closing, %s", client_id, reason)
        self.apply([Close(client_id, POLICY_VIOLATION, reason)])

    # -- effects -----------------------------------------------------------------------------

    def apply(self, effects: list[Effect], paced: set[ClientLink] | None = None) -> None:
        """Carry out effects; links that ask publishers to wait are added to `paced`."""
        if paced is None:
            paced = self._pacing
        for effect in effects:
            if type(effect) is Send:
                link = self.links.get(effect.client_id)
                translate = self._translators.get(effect.client_id)
                if translate is not None and link is not None:
                    for send in translate(effect):
                        if link.offer(send) and paced is not None:
                            paced.add(link)
                elif link is not None and link.offer(effect) and paced is not None:
                    paced.add(link)
                elif link is None and effect.client_id in self.internal_clients:
                    self.internal_clients[effect.client_id](effect)
            elif isinstance(effect, Hold):
                if effect.client_id in self.links:  # an in-process client has no reads to hold
                    self._holds[effect.client_id] = effect.until_ns
            elif isinstance(effect, Schedule):
                self._schedule(effect.key, effect.at_ns)
            elif isinstance(effect, Close):
                link = self.links.get(effect.client_id)
                if link is not None and not link.closing:
                    link.closing = True  # nothing more is sent to it or waited for
                    task = asyncio.get_running_loop().create_task(
                        close_link(link, effect.code, effect.reason)
                    )
                    self._closing.add(task)
                    task.add_done_callback(self._closing.discard)

    def _schedule(self, key: DeadlineKey, at_ns: int) -> None:
        previous = self._timers.pop(key, None)
        if previous is not None:
            previous.cancel()
        delay_s = max(0.0, (at_ns - time.time_ns()) / 1e9)
        self._timers[key] = asyncio.get_running_loop().call_later(delay_s, self._fire, key)

    def _fire(self, key: DeadlineKey) -> None:
        self._timers.pop(key, None)
        self.apply(self.core.on_deadline(key, time.time_ns()))

    def send_queue_drops(self, client_id: int) -> Mapping[str, int]:
        """Messages per topic the client's send queue dropped (empty if it is gone)."""
        link = self.links.get(client_id)
        return link.queue.dropped if link is not None else {}

    def link_health(self, client_id: int) -> LinkHealth | None:
        """Goodput, round trip and conflation of a websocket client's link (None if gone)."""
        link = self.links.get(client_id)
        return link.health() if link is not None else None

    def stats(self) -> dict[int, dict[str, object]]:
        """Per connected client: frames sent, messages dropped per topic, items waiting and
        bytes not yet taken by the client."""
        return {
            cid: {
                "frames_sent": link.frames_sent,
                "dropped": dict(link.queue.dropped),
                "waiting": len(link.queue),
                "backlog_bytes": link.backlog_bytes(),
            }
            for cid, link in self.links.items()
        }


async def close_link(link: ClientLink, code: int, reason: str) -> None:
    """Close a client's websocket; one that does not read cannot take the close frame behind
    what fills its socket, so after CLOSE_TIMEOUT_S its connection is cut."""
    try:
        async with asyncio.timeout(CLOSE_TIMEOUT_S):
            await link.ws.close(code, reason)
    except TimeoutError:
        link.ws.transport.abort()


__all__ = ["BridgeServer", "close_link", "no_observer"]
