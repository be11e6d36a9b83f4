"""A second floor for `benchmarks/relay.py --picows`: the bare relay's logic on picows (a
Cython websocket implementation) instead of websockets, to see what a faster I/O layer would
win before building an edge on it (issue 21). Frames are forwarded as they came, unvalidated,
from picows' frame callback: no task, no queue. picows is not a dependency of riverbridge:
`pip install picows` first (the flag says so when it is missing).
"""

from __future__ import annotations

import asyncio
from multiprocessing.connection import Connection
from typing import Any

MAX_FRAME_BYTES = 64 * 1024 * 1024


async def picows_relay(pipe: Connection) -> None:
    """Publish frames to the topic's subscribers, calls to the provider and answers back;
    rosapi calls answered at once (as `benchmarks.relay.floor_relay` does)."""
    import cbor2
    import orjson
    from picows import WSFrame, WSListener, WSMsgType, WSTransport, ws_create_server

    subscribers: dict[str, set[WSTransport]] = {}
    providers: dict[str, WSTransport] = {}
    callers: dict[Any, WSTransport] = {}

    def route(transport: WSTransport, kind: WSMsgType, data: bytes, op: dict[str, Any]) -> None:
        name = op["op"]
        if name == "publish":
            for sub in list(subscribers.get(op["topic"], ())):
                sub.send(kind, data)
        elif name == "subscribe":
            subscribers.setdefault(op["topic"], set()).add(transport)
        elif name == "advertise_service":
            providers[op["service"]] = transport
        elif name == "call_service" and op["service"] in providers:
            callers[op.get("id")] = transport
            providers[op["service"]].send(kind, data)
        elif name == "service_response" and op.get("id") in callers:
            callers.pop(op.get("id")).send(kind, data)
        elif name == "call_service":
            answer = {"op": "service_response", "id": op.get("id"), "service": op["service"]}
            transport.send(WSMsgType.TEXT, orjson.dumps({**answer, "values": {}, "result": True}))

    class Relay(WSListener):  # type: ignore[misc]
        def on_ws_frame(self, transport: WSTransport, frame: WSFrame) -> None:
            kind = frame.msg_type
            if kind == WSMsgType.CLOSE:
                transport.send_close(frame.get_close_code())
                transport.disconnect()
            elif kind == WSMsgType.PING:
                transport.send_pong(frame.get_payload_as_bytes())
            elif kind in (WSMsgType.TEXT, WSMsgType.BINARY):
                data = frame.get_payload_as_bytes()
                op = orjson.loads(data) if kind == WSMsgType.TEXT else cbor2.loads(data)
                route(transport, kind, data, op)

        def on_ws_disconnected(self, transport: WSTransport) -> None:
            for subs in subscribers.values():
                subs.discard(transport)

    server = await ws_create_server(
        lambda request: Relay(), "127.0.0.1", 0, max_frame_size=MAX_FRAME_BYTES
    )
    pipe.send(server.sockets[0].getsockname()[1])
    await asyncio.Future()


def run_picows_floor(pipe: Connection) -> None:
    asyncio.run(picows_relay(pipe))
