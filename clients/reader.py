"""The receive pump: websocket frames in, routed protocol events out.

Small frames are decoded on the event loop as they arrive. Frames of ``offload_bytes`` or more
go to a single decode thread in arrival order, so a multi-megabyte JSON scan is decoded while
the loop keeps delivering small messages (an IMU sample behind a scan is not held up by the
scan's decode); one thread keeps the big frames of a topic in order.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from concurrent.futures import Executor
from typing import Any

from websockets.asyncio.client import ClientConnection

from clients.connection import translate_transport_error
from clients.errors import ConnectionClosed, ProtocolError
from clients.events import Event
from clients.protocol import ClientProtocol
from schemas.errors import SchemaError

logger = logging.getLogger(__name__)

_BigFrame = tuple[bytes | str, int]


class FramePump:
    """Reads one connection until it closes and hands every event to ``deliver``.

    ``on_bad_frame`` is told about frames that could not be decoded or routed; they are
    skipped and never end the connection.
    """

    def __init__(
        self,
        protocol: ClientProtocol,
        *,
        decode_pool: Executor,
        offload_bytes: int,
        deliver: Callable[[Event], None],
        on_bad_frame: Callable[[Exception], None],
    ) -> None:
        self._protocol = protocol
        self._pool = decode_pool
        self._offload_bytes = offload_bytes
        self._deliver = deliver
        self._on_bad_frame = on_bad_frame

    async def run(self, ws: ClientConnection) -> None:
        """Pump frames until ``ws`` closes (returns normally then)."""
        big_frames: asyncio.Queue[_BigFrame | None] = asyncio.Queue()
        decoder = asyncio.create_task(self._decode_big(big_frames), name="decode big frames")
        try:
            with translate_transport_error("receive"):
                async for data in ws:
                    recv_ns = time.time_ns()
                    if len(data) >= self._offload_bytes:
                        big_frames.put_nowait((data, recv_ns))
                        continue
                    try:
                        op = self._protocol.decode(data, recv_ns=recv_ns)
                    except ProtocolError as exc:
                        self._on_bad_frame(exc)
                        continue
                    self._route(op, recv_ns, len(data))
        except ConnectionClosed as exc:
            logger.debug("%s", exc)
        finally:
            big_frames.put_nowait(None)
            await asyncio.shield(decoder)

    async def _decode_big(self, frames: asyncio.Queue[_BigFrame | None]) -> None:
        """Decode large frames in arrival order on the decode thread, then route them."""
        loop = asyncio.get_running_loop()
        while (item := await frames.get()) is not None:
            data, recv_ns = item
            try:
                op = await loop.run_in_executor(
                    self._pool, _decode_call, self._protocol, data, recv_ns
                )
            except ProtocolError as exc:
                self._on_bad_frame(exc)
                continue
            self._route(op, recv_ns, len(data))

    def _route(self, op: dict[str, Any], recv_ns: int, wire_bytes: int) -> None:
        try:
            events = self._protocol.handle(op, recv_ns=recv_ns, wire_bytes=wire_bytes)
        except (ProtocolError, SchemaError) as exc:
            self._on_bad_frame(exc)
            return
        for event in events:
            self._deliver(event)


def _decode_call(protocol: ClientProtocol, data: bytes | str, recv_ns: int) -> dict[str, Any]:
    return protocol.decode(data, recv_ns=recv_ns)
