"""`bridge.frame_scan.FrameScanner` against frames made by an independent producer
(websockets' own client-side `Frame.serialize(mask=True)`) and the bytes of RFC 6455 §5.7:
every payload length class, chunks split at every byte, control frames between data frames,
fragmented messages, reserved bits, unmasked and oversize frames."""

from __future__ import annotations

import itertools
import random

import pytest
from websockets.frames import Frame, Opcode

from bridge.frame_scan import BINARY, RAW, TEXT, FrameScanner, Kind

LIMIT = 1 << 20


def client_frame(opcode: Opcode, data: bytes, fin: bool = True) -> bytes:
    """A frame as a websockets client writes it (masked with a random key)."""
    return Frame(opcode, data, fin).serialize(mask=True)


def with_rsv1(frame: bytes) -> bytes:
    return bytes([frame[0] | 0x40]) + frame[1:]


def scan(chunks: list[bytes], max_size: int | None = LIMIT) -> list[tuple[Kind, bytes]]:
    """Every complete frame the scanner gives for `chunks` fed one by one."""
    scanner = FrameScanner(max_size)
    frames = []
    for chunk in chunks:
        scanner.feed(chunk)
        while (frame := scanner.next_frame()) is not None:
            frames.append(frame)
    return frames


def split_at(data: bytes, *cuts: int) -> list[bytes]:
    bounds = [0, *cuts, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds)]


# RFC 6455 §5.7: a single-frame masked text message "Hello", and a masked Pong.
RFC_MASKED_HELLO = bytes.fromhex("818537fa213d7f9f4d5158")
RFC_MASKED_PONG = bytes.fromhex("8a8537fa213d7f9f4d5158")
RFC_UNMASKED_HELLO = bytes.fromhex("810548656c6c6f")


def test_rfc_examples() -> None:
    assert scan([RFC_MASKED_HELLO]) == [(TEXT, b"Hello")]
    assert scan([RFC_MASKED_PONG, RFC_MASKED_HELLO]) == [
        (RAW, RFC_MASKED_PONG),
        (TEXT, b"Hello"),
    ]


@pytest.mark.parametrize("length", [0, 1, 125, 126, 127, 65535, 65536, 70000])
@pytest.mark.parametrize(("opcode", "kind"), [(Opcode.TEXT, TEXT), (Opcode.BINARY, BINARY)])
def test_every_length_class_is_unmasked(length: int, opcode: Opcode, kind: Kind) -> None:
    payload = random.Random(length).randbytes(length)
    frame = client_frame(opcode, payload)
    after = client_frame(Opcode.BINARY, b"next")
    assert scan([frame + after]) == [(kind, payload), (BINARY, b"next")]


def test_chunks_split_at_every_byte_give_the_same_frames() -> None:
    frames = [
        client_frame(Opcode.TEXT, b""),
        client_frame(Opcode.TEXT, "héllo".encode()),
        client_frame(Opcode.PING, b"ping"),
        client_frame(Opcode.BINARY, bytes(range(126))),
        client_frame(Opcode.TEXT, b"x" * 300),
        client_frame(Opcode.BINARY, b"y" * 125),
        client_frame(Opcode.CLOSE, b"\x03\xe8bye"),
    ]
    stream = b"".join(frames)
    whole = scan([stream])
    assert [kind for kind, _ in whole] == [TEXT, TEXT, RAW, BINARY, TEXT, BINARY, RAW]
    assert whole[2][1] == frames[2] and whole[6][1] == frames[6]
    for cut in range(len(stream) + 1):
        assert scan(split_at(stream, cut)) == whole, cut
    assert scan([stream[i : i + 1] for i in range(len(stream))]) == whole


def test_a_64_bit_length_frame_split_in_its_header_mask_and_payload() -> None:
    payload = b"z" * 65536
    frame = client_frame(Opcode.BINARY, payload)
    for cut in (1, 2, 3, 9, 10, 11, 13, 14, 15, len(frame) - 1):
        assert scan(split_at(frame, cut)) == [(BINARY, payload)], cut
    assert scan(split_at(frame, 1, 5, 12, 40000)) == [(BINARY, payload)]


def test_random_streams_in_random_chunks() -> None:
    """Many frames of every kind and length class, cut at random: the same as whole."""
    rng = random.Random(21)
    frames, expected = [], []
    for n in range(300):
        rare = n % 10 == 0
        length = rng.choice([0, 5, 125, 126, 200, 65535, 65536]) if rare else rng.randrange(300)
        payload = rng.randbytes(length)
        if rng.random() < 0.2:
            frame = client_frame(Opcode.PING, payload[:125])
            expected.append((RAW, frame))
        else:
            opcode, kind = rng.choice([(Opcode.TEXT, TEXT), (Opcode.BINARY, BINARY)])
            frame = client_frame(opcode, payload)
            expected.append((kind, payload))
        frames.append(frame)
    stream = b"".join(frames)
    for _ in range(5):
        cuts = sorted(rng.sample(range(1, len(stream)), 400))
        assert scan(split_at(stream, *cuts)) == expected


def test_fragmented_messages_go_to_websockets_whole_with_their_controls() -> None:
    pieces = [
        client_frame(Opcode.TEXT, b"first ", fin=False),
        client_frame(Opcode.PING, b"p"),
        client_frame(Opcode.CONT, b"second ", fin=False),
        client_frame(Opcode.CONT, b"last", fin=True),
    ]
    after = client_frame(Opcode.TEXT, b"plain")
    stream = b"".join(pieces) + after
    assert scan([stream]) == [(RAW, piece) for piece in pieces] + [(TEXT, b"plain")]
    assert scan(split_at(stream, 3, 20, 30)) == scan([stream])


def test_a_data_frame_inside_a_fragmented_message_goes_to_websockets() -> None:
    """A protocol error websockets must see (1002): the scanner does not deliver it."""
    opening = client_frame(Opcode.BINARY, b"open", fin=False)
    intruder = client_frame(Opcode.TEXT, b"not a continuation")
    assert scan([opening + intruder]) == [(RAW, opening), (RAW, intruder)]


def test_reserved_bits_and_invalid_opcodes_are_handed_on_whole() -> None:
    rsv = with_rsv1(client_frame(Opcode.TEXT, b"compressed?"))
    odd = bytes([0x83]) + client_frame(Opcode.TEXT, b"opcode 3")[1:]
    after = client_frame(Opcode.BINARY, b"after")
    assert scan([rsv + odd + after]) == [(RAW, rsv), (RAW, odd), (BINARY, b"after")]


def test_an_unmasked_frame_hands_on_everything_from_its_header() -> None:
    scanner = FrameScanner(LIMIT)
    before = client_frame(Opcode.TEXT, b"before")
    scanner.feed(before + RFC_UNMASKED_HELLO[:2])
    assert scanner.next_frame() == (TEXT, b"before")
    assert scanner.next_frame() == (RAW, RFC_UNMASKED_HELLO[:2])
    assert scanner.handing_on
    later = client_frame(Opcode.TEXT, b"later")
    scanner.feed(RFC_UNMASKED_HELLO[2:] + later)
    assert scanner.next_frame() == (RAW, RFC_UNMASKED_HELLO[2:] + later)
    assert scanner.next_frame() is None


def test_an_oversize_length_is_handed_on_at_its_header_not_buffered() -> None:
    fits = client_frame(Opcode.BINARY, b"b" * 100)
    assert scan([fits], max_size=100) == [(BINARY, b"b" * 100)]
    header = client_frame(Opcode.BINARY, b"b" * 101)[:6]
    assert scan([header], max_size=100) == [(RAW, header)]
    huge = bytes([0x82, 0xFF]) + (1 << 40).to_bytes(8, "big")  # 1 TiB announced
    scanner = FrameScanner(4096)
    scanner.feed(huge[:5])
    assert scanner.next_frame() is None  # the length is not all there yet
    scanner.feed(huge[5:] + b"mask" + b"data")
    assert scanner.next_frame() == (RAW, huge + b"maskdata")
    assert scanner.handing_on


def test_no_limit_without_max_size() -> None:
    payload = b"u" * 200_000
    assert scan(split_at(client_frame(Opcode.BINARY, payload), 7, 100), None) == [(BINARY, payload)]


def test_a_partial_frame_waits_and_take_rest_returns_it() -> None:
    frame = client_frame(Opcode.TEXT, b"x" * 1000)
    scanner = FrameScanner(LIMIT)
    scanner.feed(client_frame(Opcode.TEXT, b"whole") + frame[:500])
    assert scanner.next_frame() == (TEXT, b"whole")
    assert scanner.next_frame() is None
    scanner.feed(frame[500:600])
    assert scanner.next_frame() is None
    assert scanner.take_rest() == frame[:600]
    assert scanner.next_frame() is None
