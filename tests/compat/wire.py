"""A plain rosbridge peer on a raw `websockets` connection: the Python side of each scenario.

The client under test (roslibpy, roslibjs, a Lichtblick- or ROS#-shaped peer) is the thing
being checked; the other side of a scenario (a publisher, a service provider, a subscriber)
only needs to speak the documented wire format, so it is written here as raw frames. Every
frame received is kept in `history`, so a test can also assert what the bridge did NOT send.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
from collections.abc import AsyncIterator, Callable, Iterable
from dataclasses import dataclass
from typing import Any

import cbor2
from websockets.asyncio.client import ClientConnection, connect

# Generous: the bridge, node and pytest share two loaded cores.
DEFAULT_TIMEOUT_S = 20.0


@dataclass(frozen=True)
class Received:
    """One websocket message from the bridge: raw payload and its decoded rosbridge op."""

    raw: str | bytes
    message: dict[str, Any]

    @property
    def binary(self) -> bool:
        return isinstance(self.raw, bytes)


def _decode(raw: str | bytes) -> dict[str, Any]:
    """Text frames are JSON; binary frames are CBOR (the only binary the bridge may send)."""
    if isinstance(raw, str):
        return json.loads(raw)
    return cbor2.loads(raw)


class WirePeer:
    """A rosbridge connection driven frame by frame.

    `expect(predicate)` returns (and consumes) the oldest received message that matches, in
    arrival order, waiting up to a timeout; non-matching messages stay queued for later calls.
    """

    def __init__(self, connection: ClientConnection) -> None:
        self.connection = connection
        self.history: list[Received] = []
        self._pending: list[Received] = []
        self._arrived = asyncio.Event()
        self._ids = itertools.count(1)
        self._reader = asyncio.create_task(self._read())

    async def _read(self) -> None:
        with contextlib.suppress(Exception):
            async for raw in self.connection:
                received = Received(raw, _decode(raw))
                self.history.append(received)
                self._pending.append(received)
                self._arrived.set()

    def next_id(self, prefix: str) -> str:
        return f"{prefix}:{next(self._ids)}"

    async def send(self, message: dict[str, Any]) -> None:
        """Send one op as JSON in a text frame (what roslibpy, roslibjs and Lichtblick do)."""
        await self.connection.send(json.dumps(message))

    async def send_fragmented_binary(self, text: str, fragment_bytes: int) -> None:
        """Send JSON text as one binary message split into websocket continuation frames."""
        payload = text.encode("ascii")
        chunks: Iterable[bytes] = (
            payload[start : start + fragment_bytes]
            for start in range(0, len(payload), fragment_bytes)
        )
        await self.connection.send(chunks)

    async def expect(
        self,
        predicate: Callable[[dict[str, Any]], bool],
        timeout_s: float = DEFAULT_TIMEOUT_S,
        what: str = "a matching message",
    ) -> Received:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_s
        while True:
            for index, item in enumerate(self._pending):
                if predicate(item.message):
                    return self._pending.pop(index)
            remaining = deadline - loop.time()
            if remaining <= 0:
                seen = [_summary(item) for item in self.history[-10:]]
                raise AssertionError(f"no {what} within {timeout_s} s; last frames: {seen}")
            self._arrived.clear()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._arrived.wait(), remaining)

    async def expect_op(self, op: str, timeout_s: float = DEFAULT_TIMEOUT_S, **fields) -> Received:
        def matches(message: dict[str, Any]) -> bool:
            return message.get("op") == op and all(message.get(k) == v for k, v in fields.items())

        return await self.expect(matches, timeout_s, what=f"{op} with {fields}")

    async def call_service(
        self, service: str, args: dict[str, Any] | None = None, **extra: Any
    ) -> dict[str, Any]:
        """Call a service and return the whole `service_response` (also an ordering barrier:
        the bridge handles one connection's ops in order, so everything sent before is done)."""
        call_id = self.next_id(f"call_service:{service}")
        message = {"op": "call_service", "id": call_id, "service": service, "args": args or {}}
        await self.send({**message, **extra})
        received = await self.expect_op("service_response", id=call_id)
        return received.message

    def received_ops(self) -> list[str]:
        return [item.message.get("op", "?") for item in self.history]

    async def close(self) -> None:
        await self.connection.close()
        with contextlib.suppress(Exception):
            await asyncio.wait_for(self._reader, 5.0)


def _summary(item: Received) -> str:
    kind = "binary" if item.binary else "text"
    text = repr(item.message)
    return f"{kind} {text[:200]}"


@contextlib.asynccontextmanager
async def wire_peer(url: str) -> AsyncIterator[WirePeer]:
    """Connect like a plain client: no permessage-deflate, no frame size limit."""
    async with connect(url, compression=None, max_size=None, open_timeout=30) as connection:
        peer = WirePeer(connection)
        try:
            yield peer
        finally:
            await peer.close()


async def wait_until_listed(
    peer: WirePeer, rosapi_service: str, key: str, name: str, timeout_s: float = DEFAULT_TIMEOUT_S
) -> dict[str, Any]:
    """Poll a rosapi list service (e.g. `/rosapi/services`, key `services`) until `name` shows."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while True:
        response = await peer.call_service(rosapi_service)
        values = response.get("values")
        if response.get("result") and isinstance(values, dict) and name in values.get(key, []):
            return response
        if loop.time() > deadline:
            raise AssertionError(f"{name} never appeared in {rosapi_service}: last {response}")
        await asyncio.sleep(0.1)
