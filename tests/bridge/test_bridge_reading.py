"""The inbound data path (`bridge.reading`) over real sockets: messages from websockets' parser
straight to the bridge behave as `recv()` delivered them: fragmented messages are joined, text
must be UTF-8 (1007), oversize messages and too many fragments close with 1009, a client's
last messages before it closes are still handled, and a client that sends thousands of
messages in one write gets each handled once, in order. A raw TCP client writing hand-built
frames in awkward pieces checks the frame scanner shared with websockets' parser: pings
answered mid-stream, fragments joined around a ping, 1007, 1009 and 1002 as before."""

from __future__ import annotations

import asyncio
import fcntl
import itertools
import json
import struct
import termios
from typing import Any

import pytest
import websockets
from websockets.asyncio.messages import MAX_FRAGMENTS
from websockets.client import ClientProtocol
from websockets.exceptions import ConnectionClosed
from websockets.frames import Close, Frame, Opcode
from websockets.http11 import Response
from websockets.uri import parse_uri
from websockets.utils import apply_mask as pure_apply_mask

from bridge.compose import RunningBridge, run_bridge
from bridge.config import BridgeConfig
from bridge.reading import FrameConnection
from schemas import codec_cbor

pytestmark = pytest.mark.timeout(60)

TOPIC, TYPE = "/chatter", "std_msgs/msg/String"


async def connect(url: str) -> websockets.ClientConnection:
    return await websockets.connect(url, compression=None, max_size=None)


async def subscriber(url: str, compression: str = "none") -> websockets.ClientConnection:
    """A client subscribed to TOPIC, once the bridge has handled its subscribe."""
    ws = await connect(url)
    op = {"op": "subscribe", "topic": TOPIC, "type": TYPE, "compression": compression}
    await ws.send(json.dumps(op))
    await ws.send(json.dumps({"op": "call_service", "service": "/rosapi/get_time", "id": "s"}))
    async with asyncio.timeout(10):
        while '"service_response"' not in str(await ws.recv()):
            pass
    return ws


def publish(data: str) -> str:
    return json.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": data}})


async def next_data(ws: websockets.ClientConnection) -> str:
    async with asyncio.timeout(10):
        frame = await ws.recv()
    op = json.loads(frame) if isinstance(frame, str) else codec_cbor.loads(frame)
    data: str = op["msg"]["data"]
    return data


async def closed_with(ws: websockets.ClientConnection) -> int | None:
    """The close code the bridge sent once it closed `ws`."""
    async with asyncio.timeout(10):
        with pytest.raises(ConnectionClosed):
            while True:
                await ws.recv()
    return ws.close_code


async def test_fragmented_text_and_binary_messages_are_joined() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        text = publish("joined " + "t" * 3000)
        await pub.send([text[i : i + 100] for i in range(0, len(text), 100)])  # 31 frames
        assert await next_data(sub) == "joined " + "t" * 3000
        binary = codec_cbor.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": "cbor"}})
        await pub.send([binary[:7], binary[7:20], binary[20:]])
        assert await next_data(sub) == "cbor"
        await pub.send(publish("after"))  # the connection goes on as before
        assert await next_data(sub) == "after"


async def test_invalid_utf8_in_a_text_frame_closes_with_1007() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        bad = b'{"op": "publish", "topic": "/chatter", "msg": {"data": "\xff"}}'
        await pub.send(bad, text=True)
        assert await closed_with(pub) == 1007
        other = await connect(bridge.url)  # the bridge and its other clients go on
        await other.send(publish("still here"))
        assert await next_data(sub) == "still here"


async def test_oversize_messages_close_with_1009_whole_or_fragmented() -> None:
    async with run_bridge(BridgeConfig(port=0, max_message_size=4096)) as bridge:
        sub = await subscriber(bridge.url)
        whole = await connect(bridge.url)
        await whole.send(publish("x" * 5000))
        assert await closed_with(whole) == 1009
        pieces = await connect(bridge.url)
        await pieces.send(["x" * 1000] * 5)  # each fragment fits, the message does not
        assert await closed_with(pieces) == 1009
        fits = await connect(bridge.url)
        await fits.send(publish("y" * 3000))
        assert await next_data(sub) == "y" * 3000


async def test_too_many_fragments_close_with_1009() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        pub = await connect(bridge.url)
        await pub.send(["x"] * (MAX_FRAGMENTS + 1))
        assert await closed_with(pub) == 1009


async def test_messages_sent_just_before_closing_are_handled() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        pub = await connect(bridge.url)
        for n in range(50):
            await pub.send(publish(f"last {n}"))
        await pub.close()
        assert [await next_data(sub) for _ in range(50)] == [f"last {n}" for n in range(50)]


async def test_thousands_of_messages_in_one_write_are_each_handled_once_in_order() -> None:
    """One socket write holds 3,000 publishes: far more than one turn (`TURN_S`) handles, so
    the reader pauses and goes on several times; CBOR for the subscriber."""
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url, "cbor")
        pub = await connect(bridge.url)
        count = 3000
        async with pub.send_context():  # frame them all, then write them at once
            for n in range(count):
                pub.protocol.send_text(publish(f"{n} " + "x" * 80).encode())
        got = [await next_data(sub) for _ in range(count)]
        assert [int(data.split()[0]) for data in got] == list(range(count))


# Hand-built frames over a plain TCP socket: the bridge's frame scanner (`frame_scan.py`) and
# websockets' parser share each connection; pieces cut inside headers, masks and payloads.

MASK = b"\x37\xfa\x21\x3d"  # RFC 6455 §5.7's


def masked(opcode: int, payload: bytes, fin: bool = True, mask: bytes = MASK) -> bytes:
    """A client frame built by hand (RFC 6455 §5.2), masked with pure-Python unmasking."""
    length = len(payload)
    if length < 126:
        size = bytes([0x80 | length])
    elif length < 65536:
        size = bytes([0x80 | 126]) + length.to_bytes(2, "big")
    else:
        size = bytes([0x80 | 127]) + length.to_bytes(8, "big")
    return bytes([(0x80 if fin else 0) | opcode]) + size + mask + pure_apply_mask(payload, mask)


def text(data: str) -> bytes:
    return masked(0x1, publish(data).encode())


FIONREAD = termios.FIONREAD  # bytes received and not yet read; TIOCOUTQ: sent, not acked


def unread_bytes(sock: Any, request: int) -> int:
    count: int = struct.unpack("i", fcntl.ioctl(sock.fileno(), request, b"\0" * 4))[0]
    return count


class RawClient:
    """A client on a plain TCP socket writing hand-built bytes in pieces of its choosing;
    websockets' sans-I/O `ClientProtocol` makes its handshake and reads what the bridge sends."""

    def __init__(self, bridge: RunningBridge, after_request: bytes = b"") -> None:
        self.bridge = bridge
        self.after_request = after_request  # written with the request, in the same write
        self.protocol = ClientProtocol(parse_uri(bridge.url), max_size=None)
        self.events: list[Any] = []

    async def __aenter__(self) -> RawClient:
        """The handshake (and what the client writes before its answer)."""
        self.reader, self.writer = await asyncio.open_connection(self.bridge.host, self.bridge.port)
        self.protocol.send_request(self.protocol.connect())
        self.writer.write(b"".join(self.protocol.data_to_send()) + self.after_request)
        response = await self.next_event()
        assert isinstance(response, Response) and response.status_code == 101
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.writer.close()
        await self.writer.wait_closed()

    async def send(self, *pieces: bytes) -> None:
        """Write each piece alone and wait until the bridge has read it: each reaches the
        bridge as a chunk of its own."""
        ours = self.writer.get_extra_info("socket")
        async with asyncio.timeout(10):
            theirs = (await self.bridge_connection()).transport.get_extra_info("socket")
            for piece in pieces:
                self.writer.write(piece)
                await self.writer.drain()
                while unread_bytes(ours, termios.TIOCOUTQ) or unread_bytes(theirs, FIONREAD):
                    await asyncio.sleep(0.001)

    async def bridge_connection(self) -> FrameConnection:
        """The bridge's end of this connection, once its link is up."""
        name = self.writer.get_extra_info("sockname")
        while True:
            for link in self.bridge.server.links.values():
                if link.ws.remote_address == name:
                    return link.ws
            await asyncio.sleep(0.001)

    async def next_event(self) -> Any:
        async with asyncio.timeout(10):
            while not self.events:
                data = await self.reader.read(65536)
                assert data, "the bridge closed the TCP connection"
                self.protocol.receive_data(data)
                self.events.extend(self.protocol.events_received())
                self.writer.write(b"".join(self.protocol.data_to_send()))
        return self.events.pop(0)

    async def next_frame(self, opcode: Opcode) -> bytes:
        while not isinstance(event := await self.next_event(), Frame) or event.opcode is not opcode:
            pass
        return bytes(event.data)

    async def close_code(self) -> int:
        return Close.parse(await self.next_frame(Opcode.CLOSE)).code


async def test_hand_built_frames_cut_at_awkward_points_are_each_handled_in_order() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            big = codec_cbor.dumps({"op": "publish", "topic": TOPIC, "msg": {"data": "b" * 70000}})
            frames = [text("short"), text("m" * 3000), masked(0x2, big), text("last")]
            stream = b"".join(frames)
            at = [0, *itertools.accumulate(len(f) for f in frames)]
            cuts = [
                1,  # the first header byte alone
                at[1] + 3,  # inside the 16-bit length
                at[1] + 6,  # inside the mask
                at[2] + 5,  # inside the 64-bit length
                at[2] + 20000,  # inside the payload
                at[3] + 1,  # the big frame's end with the next frame's first byte
            ]
            await raw.send(*(stream[a:b] for a, b in itertools.pairwise([0, *cuts, len(stream)])))
            assert [await next_data(sub) for _ in frames] == [
                "short",
                "m" * 3000,
                "b" * 70000,
                "last",
            ]


async def test_a_ping_between_data_frames_is_answered_in_order() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            stream = text("before") + masked(0x9, b"mid-stream") + text("after")
            cut = len(text("before")) + 3  # inside the ping's mask
            await raw.send(stream[:cut], stream[cut:])
            assert await raw.next_frame(Opcode.PONG) == b"mid-stream"
            assert [await next_data(sub), await next_data(sub)] == ["before", "after"]


async def test_the_bridge_s_own_ping_is_acknowledged_by_a_pong_between_data_frames() -> None:
    """websockets' keepalive waits for its ping's pong: a pong cut between two data frames
    still reaches it."""
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            pong_waiter = await (await raw.bridge_connection()).ping(b"keepalive")
            assert await raw.next_frame(Opcode.PING) == b"keepalive"
            stream = text("before") + masked(0xA, b"keepalive") + text("after")
            cut = len(text("before")) + 4  # inside the pong's mask
            await raw.send(stream[:cut], stream[cut:])
            async with asyncio.timeout(10):
                await pong_waiter
            assert [await next_data(sub), await next_data(sub)] == ["before", "after"]


async def test_a_fragmented_message_with_a_ping_inside_is_joined_in_order() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            whole = publish("in pieces").encode()
            frames = [
                text("first"),
                masked(0x1, whole[:20], fin=False),
                masked(0x9, b"inside"),
                masked(0x0, whole[20:30], fin=False),
                masked(0x0, whole[30:], fin=True),
                text("then"),
            ]
            stream = b"".join(frames)
            at = list(itertools.accumulate(len(f) for f in frames))
            await raw.send(stream[: at[1] + 2], stream[at[1] + 2 : at[3] + 7], stream[at[3] + 7 :])
            assert await raw.next_frame(Opcode.PONG) == b"inside"
            assert [await next_data(sub) for _ in range(3)] == ["first", "in pieces", "then"]


async def test_bad_utf8_on_the_fast_path_closes_1007_and_what_follows_is_dropped() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            bad = masked(0x1, b'{"op": "publish", "topic": "/chatter", "msg": {"data": "\xff"}}')
            raw.writer.write(bad + text("dropped"))
            assert await raw.close_code() == 1007
            other = await connect(bridge.url)
            await other.send(publish("next"))
            assert await next_data(sub) == "next"


async def test_an_oversize_header_closes_1009_before_its_payload_comes() -> None:
    async with (
        run_bridge(BridgeConfig(port=0, max_message_size=4096)) as bridge,
        RawClient(bridge) as raw,
    ):
        raw.writer.write(bytes([0x82, 0xFF]) + (1 << 40).to_bytes(8, "big") + MASK)  # 1 TiB
        assert await raw.close_code() == 1009


async def test_an_unmasked_frame_closes_1002() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge, RawClient(bridge) as raw:
        raw.writer.write(text("masked") + bytes.fromhex("810548656c6c6f"))  # RFC 6455 §5.7
        assert await raw.close_code() == 1002


async def test_a_new_message_inside_a_fragmented_one_closes_1002_and_is_not_handled() -> None:
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        async with RawClient(bridge) as raw:
            raw.writer.write(masked(0x1, b'{"op": ', fin=False) + text("intruder"))
            assert await raw.close_code() == 1002
        other = await connect(bridge.url)
        await other.send(publish("next"))
        assert await next_data(sub) == "next"


async def test_frames_written_with_the_request_are_handled_in_order() -> None:
    """A client that does not wait for the handshake's answer: websockets reads that
    connection alone. The write ends just after a frame's mask: websockets has nothing
    buffered but is inside that frame, whose payload (a zero mask leaves it as is) is itself
    a frame: read from there, it would be taken for a publish."""
    async with run_bridge(BridgeConfig(port=0)) as bridge:
        sub = await subscriber(bridge.url)
        outer = masked(0x2, text("inner"), mask=bytes(4))
        assert len(text("inner")) < 126  # two header bytes and the mask: 6
        async with RawClient(bridge, after_request=text("pipelined") + outer[:6]) as raw:
            await raw.send(outer[6:], text("later"))
        assert [await next_data(sub) for _ in range(2)] == ["pipelined", "later"]
