"""Drive the sans-I/O core without sockets: a fake clock, deadlines and decoded outboxes."""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import replace
from typing import Any

from bridge.config import BridgeConfig
from bridge.core import BridgeCore
from bridge.effects import Close, Effect, Hold, Schedule, Send
from bridge.inbound import read_frame
from bridge.outgoing import WireFrame, render
from schemas import codec_cbor, codec_json
from schemas.errors import SchemaError
from schemas.registry import TypeRegistry

START_NS = 1_700_000_000 * 1_000_000_000


class CoreHarness:
    """A `BridgeCore` plus the bits of the edge tests need: clock, timers, outboxes."""

    def __init__(self, registry: TypeRegistry, **config: Any) -> None:
        self.core = BridgeCore(BridgeConfig(**config), registry)
        self.now_ns = START_NS
        self.deadlines: dict[Any, int] = {}
        self.sends: dict[int, list[Send]] = defaultdict(list)
        self.closes: list[Close] = []
        self.holds: list[Hold] = []  # read nothing more of a client until (bridge.roles quotas)

    @property
    def state(self):
        return self.core.state

    def connect(self) -> int:
        return self.core.connect("test")

    def disconnect(self, client: int) -> None:
        self._record(self.core.disconnect(client, self.now_ns))

    def send(self, client: int, op: dict[str, Any] | bytes | str) -> None:
        """Deliver one frame from `client`: a dict goes as a JSON text frame."""
        data = json.dumps(op) if isinstance(op, dict) else op
        self._record(self.core.receive(client, data, self.now_ns, self.now_ns))

    def receive_offloaded(self, client: int, frame: bytes | str) -> None:
        """Deliver a frame the way the edge does: decode it, run the check the core wants off
        the loop (`offload`; here, at once), then hand both to the core."""
        try:
            inbound = read_frame(frame, self.now_ns)
        except SchemaError as exc:
            self._record(self.core.receive_invalid(client, str(exc), self.now_ns))
            return
        work = self.core.offload(inbound, self.now_ns)
        if work is not None:
            inbound = replace(inbound, checked=work.run())
        self._record(self.core.receive_frame(client, inbound, self.now_ns))

    def advance(self, seconds: float) -> None:
        """Move the clock, firing due deadlines in time order."""
        target = self.now_ns + int(seconds * 1e9)
        while True:
            due = [(at, key) for key, at in self.deadlines.items() if at <= target]
            if not due:
                break
            at, key = min(due, key=lambda item: item[0])
            del self.deadlines[key]
            self.now_ns = max(self.now_ns, at)
            self._record(self.core.on_deadline(key, self.now_ns))
        self.now_ns = target

    def _record(self, effects: list[Effect]) -> None:
        for effect in effects:
            if isinstance(effect, Send):
                self.sends[effect.client_id].append(effect)
            elif isinstance(effect, Schedule):
                self.deadlines[effect.key] = effect.at_ns
            elif isinstance(effect, Hold):
                self.holds.append(effect)
            else:
                self.closes.append(effect)

    def frames(self, client: int) -> list[WireFrame]:
        """Render and take everything queued for `client` (fragmenting like the edge)."""
        sends, self.sends[client] = self.sends[client], []
        return [f for s in sends for f in render(s.item, s.fragment_size, "frag")]

    def outbox(self, client: int) -> list[Any]:
        """Decoded messages sent to `client` since the last call."""
        return [
            codec_json.loads(f.data) if f.text else codec_cbor.loads(f.data)
            for f in self.frames(client)
        ]

    def call(self, client: int, service: str, args: Any = None, **extra: Any) -> dict[str, Any]:
        """Call a service and return the single response the caller got."""
        op = {"op": "call_service", "service": service, "id": "call", **extra}
        if args is not None:
            op["args"] = args
        self.send(client, op)
        responses = [m for m in self.outbox(client) if m.get("op") == "service_response"]
        assert len(responses) == 1, responses
        return responses[0]
