"""The client library's sans-I/O protocol wired to the bridge's sans-I/O core, in memory.

`clients.protocol.ClientProtocol` makes frames and reads them; `bridge.core.BridgeCore` (driven
by `tests.bridge.bridge_harness.CoreHarness`: fake clock, timers, rendered outboxes) answers
them. A `MemoryPair` carries each frame from one to the other exactly as bytes or text, so a
protocol test sees what the two sides really say to each other, without sockets, threads or
an event loop. Only tests may import both sides; the packages never do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from clients.events import Event
from clients.protocol import ClientProtocol, Encoding
from clients.wire import Frame
from schemas.registry import TypeRegistry
from tests.bridge.bridge_harness import CoreHarness


@dataclass(frozen=True)
class MemoryClient:
    """One client connection: its protocol and the id the core knows it by."""

    protocol: ClientProtocol
    client_id: int


class MemoryPair:
    """A bridge core with any number of in-memory clients (``config``: `BridgeConfig` fields)."""

    def __init__(self, registry: TypeRegistry, **config: Any) -> None:
        self.registry = registry
        self.harness = CoreHarness(registry, **config)

    def client(self, encoding: Encoding = "json") -> MemoryClient:
        """Connect a new client speaking `encoding`."""
        protocol = ClientProtocol(encoding=encoding, spec_lookup=self.registry.message)
        return MemoryClient(protocol, self.harness.connect())

    def send(self, client: MemoryClient, *frames: Frame | None) -> None:
        """Deliver `client`'s frames to the core (a ``None`` frame, nothing to send, is skipped)."""
        for frame in frames:
            if frame is not None:
                self.harness.send(
                    client.client_id, frame.data.decode() if frame.text else frame.data
                )

    def events(self, client: MemoryClient) -> list[Event]:
        """Everything the core sent `client` since the last call, read by its protocol."""
        return [
            event
            for wire in self.harness.frames(client.client_id)
            for event in client.protocol.receive(
                wire.data.decode() if wire.text else wire.data, recv_ns=self.harness.now_ns
            )
        ]

    def events_of(self, client: MemoryClient, kind: type[Event]) -> Sequence[Any]:
        """The events of one kind among :meth:`events` (the others are dropped)."""
        return [event for event in self.events(client) if isinstance(event, kind)]
