"""Websocket frame headers for the bridge's outgoing frames (RFC 6455 §5.2), kept pure.

The edge writes a frame as its header followed by the payload the message already holds,
without websockets' per-frame `Frame` object and `BytesIO` (a few microseconds for every small
frame of a burst). Only unmasked, unfragmented frames of a connection without extensions are
built here: what a server sends when permessage-deflate is off; anything else goes through
websockets.
"""

from __future__ import annotations

import struct

OP_TEXT = 0x1
OP_BINARY = 0x2
_FIN = 0x80
_SHORT_MAX = 125  # payload lengths up to this fit in the second header byte
_MEDIUM_MAX = 0xFFFF  # up to this, a 16-bit extended length; beyond, 64-bit
_MEDIUM = struct.Struct("!BBH")
_LONG = struct.Struct("!BBQ")


def frame_header(text: bool, length: int) -> bytes:
    """The 2-10 header bytes of a final, unmasked text or binary frame of `length` bytes."""
    head = _FIN | (OP_TEXT if text else OP_BINARY)
    if length <= _SHORT_MAX:
        return bytes((head, length))
    if length <= _MEDIUM_MAX:
        return _MEDIUM.pack(head, 126, length)
    return _LONG.pack(head, 127, length)
