"""`LinkEmulator`: a TCP proxy that carries each connection over an emulated link.

```python
async with LinkEmulator("4g", upstream=("127.0.0.1", bridge_port)) as link:
    url = f"ws://127.0.0.1:{link.port}"  # connect the client here
```

Each accepted connection gets its own upstream connection and two pumps, one per direction
(`clients.linkemu.timing` says when bytes leave and arrive). A pump reads its source only while
the bottleneck queue has room, and both sockets have small kernel buffers, so a full link
pushes back on the sender as a real bottleneck would: the bridge sees its own socket back up.
Nothing is lost or reordered; a stall holds both directions.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import random
import socket
from collections import deque
from collections.abc import Coroutine
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

from clients.linkemu.profiles import Direction, LinkProfile, profile_named
from clients.linkemu.timing import DirectionTiming, StallSchedule

logger = logging.getLogger("clients.linkemu")

# Kernel buffers of the proxy's sockets: small, so that the bytes waiting for the link stay in
# the emulated queue (bounded) and the sender's own socket, not in loopback buffers megabytes
# deep that no real link has. (The kernel doubles the figure and advertises about half.) The
# proxy reads its sockets itself, only when the queue has room: no stream buffer hides bytes.
SOCKET_BUFFER_BYTES = 8 * 1024
DIRECTIONS = ("to_client", "to_server")
# The segment size the proxy's sockets announce: Ethernet's, not loopback's 64 KiB, whose
# segments would let the peer's kernel size its send buffer at megabytes (ten initial segments
# of 64 KiB, twice) where a real path gives it tens of kilobytes.
SEGMENT_BYTES = 1448


@dataclass
class LinkStats:
    """Bytes carried each way since the emulator started, and the connections it accepted."""

    carried_bytes: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DIRECTIONS, 0))
    peak_queue_bytes: dict[str, int] = field(default_factory=lambda: dict.fromkeys(DIRECTIONS, 0))
    connections: int = 0


def _small_buffers(sock: socket.socket) -> None:
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, SOCKET_BUFFER_BYTES)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCKET_BUFFER_BYTES)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_MAXSEG, SEGMENT_BYTES)


class LinkEmulator:
    """Listens on `host`:`port` (0: any free port, see `.port`) and forwards to `upstream`."""

    def __init__(
        self,
        profile: LinkProfile | str,
        upstream: tuple[str, int],
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        seed: int | None = 0,
    ) -> None:
        self.profile = profile_named(profile) if isinstance(profile, str) else profile
        self.upstream = upstream
        self.stats = LinkStats()
        self._host, self._port = host, port
        self._rng = random.Random(seed)
        self._stalls = StallSchedule(self.profile.stall_every_s, self.profile.stall_ms, self._rng)
        self._listener: socket.socket | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self._epoch = 0.0

    @property
    def port(self) -> int:
        if self._listener is None:
            raise RuntimeError("the link emulator is not running")
        port: int = self._listener.getsockname()[1]
        return port

    def now_s(self) -> float:
        """Emulator time: seconds since it started (the stall schedule's clock)."""
        return asyncio.get_running_loop().time() - self._epoch

    def stalled_s(self) -> float:
        """Seconds the link has been stalled so far."""
        return self._stalls.stalled_s(self.now_s())

    async def start(self) -> None:
        listener = socket.create_server((self._host, self._port))
        _small_buffers(listener)  # accepted sockets inherit the buffer sizes
        listener.setblocking(False)
        self._listener = listener
        self._epoch = asyncio.get_running_loop().time()
        self._spawn(self._accept_forever(listener))

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        if self._listener is not None:
            self._listener.close()
            self._listener = None

    async def __aenter__(self) -> LinkEmulator:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.stop()

    def _spawn(self, coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.get_running_loop().create_task(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _accept_forever(self, listener: socket.socket) -> None:
        loop = asyncio.get_running_loop()
        while True:
            client, _ = await loop.sock_accept(listener)
            client.setblocking(False)
            self._spawn(self._carry(client))

    async def _connect_upstream(self) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            _small_buffers(sock)  # before connecting, so the window is small from the start
            sock.setblocking(False)
            await asyncio.get_running_loop().sock_connect(sock, self.upstream)
        except BaseException:
            sock.close()
            raise
        return sock

    async def _carry(self, client: socket.socket) -> None:
        """One connection: pump both ways until both sides are done, then close both."""
        self.stats.connections += 1
        try:
            server = await self._connect_upstream()
        except OSError as exc:
            logger.warning("link emulator: cannot reach upstream %s: %s", self.upstream, exc)
            client.close()
            return
        try:
            await asyncio.gather(
                self._pump(client, server, self.profile.to_server, "to_server"),
                self._pump(server, client, self.profile.to_client, "to_client"),
            )
        finally:
            client.close()
            server.close()

    async def _pump(
        self, source: socket.socket, sink: socket.socket, direction: Direction, name: str
    ) -> None:
        timing = DirectionTiming(direction, self._stalls, self._rng)
        arrivals: deque[tuple[float, bytes]] = deque()
        ready = asyncio.Event()
        deliver = asyncio.get_running_loop().create_task(self._deliver(sink, arrivals, ready))
        try:
            await self._admit(source, timing, arrivals, ready, name)
        finally:
            arrivals.append((float("-inf"), b""))  # end of stream, after what is in flight
            ready.set()
            with contextlib.suppress(Exception):
                await deliver
            if not deliver.done():
                deliver.cancel()
            with contextlib.suppress(OSError):
                sink.shutdown(socket.SHUT_WR)  # the other end learns that this side is done

    async def _admit(
        self,
        source: socket.socket,
        timing: DirectionTiming,
        arrivals: deque[tuple[float, bytes]],
        ready: asyncio.Event,
        name: str,
    ) -> None:
        """Read `source` a chunk at a time, each only once the bottleneck queue has room."""
        loop = asyncio.get_running_loop()
        chunk = min(timing.chunk_bytes(), timing.direction.buffer_bytes)
        while True:
            now_s = self.now_s()
            wait_s = timing.room_at(now_s, chunk) - now_s
            if wait_s > 0:
                await asyncio.sleep(wait_s)
            try:
                data = await loop.sock_recv(source, chunk)
            except OSError:
                return
            if not data:
                return
            now_s = self.now_s()
            _, arrive_s = timing.transmit(now_s, len(data))
            stats = self.stats
            stats.peak_queue_bytes[name] = max(
                stats.peak_queue_bytes[name], timing.queued_bytes(now_s)
            )
            stats.carried_bytes[name] += len(data)
            arrivals.append((arrive_s, data))
            ready.set()
            self._stalls.forget_before(now_s - 60)

    async def _deliver(
        self, sink: socket.socket, arrivals: deque[tuple[float, bytes]], ready: asyncio.Event
    ) -> None:
        """Write each chunk to `sink` once its arrival time has come; end at the end marker."""
        loop = asyncio.get_running_loop()
        while True:
            while not arrivals:
                ready.clear()
                await ready.wait()
            arrive_s, data = arrivals[0]
            if not data:
                return
            wait_s = arrive_s - self.now_s()
            if wait_s > 0:
                await asyncio.sleep(wait_s)
            due: list[bytes] = []
            now_s = self.now_s()
            while arrivals and arrivals[0][1] and arrivals[0][0] <= now_s:
                due.append(arrivals.popleft()[1])
            try:
                await loop.sock_sendall(sink, b"".join(due))
            except OSError:
                return
