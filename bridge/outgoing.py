"""Outgoing items and their wire frames, encoded once and shared by every recipient.

A `TopicMessage` is one message published on a topic. Its frames are computed lazily, at
most once per (encoding, topic spelling), under a lock so that worker threads rendering the
same message for several subscribers wait for one encode instead of repeating it. The edge
renders items whose payload is large in a thread pool, off the event loop.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import cached_property
from typing import Any

from mypy_extensions import mypyc_attr

from bridge.reduction import CloudReducer, ReduceRequest, Reduction, budget_for_link
from schemas import codec_json
from schemas.codec_cdr import to_cdr
from schemas.codec_png import encode_png_op
from schemas.errors import SchemaError
from schemas.frames import (
    fragments_cbor,
    fragments_json,
    publish_cbor,
    publish_cbor_raw,
    publish_json,
)
from schemas.message import payload_bytes
from schemas.registry import TypeRegistry

JSON = "none"
PNG = "png"
CBOR = "cbor"
CBOR_RAW = "cbor-raw"
# Smallest outgoing fragment in characters; smaller requested sizes are raised to it. Smaller
# fragments only multiply the envelope and the id each one repeats (amplification), and no
# rosbridge client asks for less (ROS# sends 2^31 - 1: "never fragment").
MIN_FRAGMENT_SIZE = 1000
# Subscription compression precedence (protocol §4.4): the strongest wins among a client's ids.
COMPRESSION_RANK = {JSON: 0, PNG: 1, CBOR: 2, CBOR_RAW: 3}


@dataclass(slots=True)  # (not frozen, as `Delivery`: one per message)
class WireFrame:
    """One websocket frame: `data` is UTF-8 JSON when `text`, else binary (CBOR);
    `reduction` says what was done to a thinned point cloud (on its first frame)."""

    data: bytes
    text: bool
    reduction: Reduction | None = None


# Messages smaller than this are encoded without taking their lock (see `TopicMessage.frame`).
UNLOCKED_ENCODE_BYTES = 64 * 1024
_MAKING_LOCKS = threading.Lock()


class TopicMessage:
    """A canonical message published on `topic`, with per-encoding frames cached.

    `stamp_ns` is the bridge wall-clock time the message entered the graph; it fills the
    `secs`/`nsecs` of cbor-raw frames. `cdr` may be given by a middleware source that already
    holds the serialized form (then cbor-raw needs no encode). `size_hint` (how costly an
    encode will be) and `cdr_bytes` (the serialized size, for tracing) may come precomputed
    from a worker thread; otherwise the first is derived here and the second left to whoever
    needs it. `has_float32` (whether JSON must widen float32 arrays) comes from the caller that
    holds the type's spec; otherwise it is looked up when JSON is first encoded.
    """

    __slots__ = (
        "_frames",
        "_has_float32",
        "_lock",
        "_reducer",
        "cdr",
        "cdr_bytes",
        "msg",
        "registry",
        "size_hint",
        "stamp_ns",
        "topic",
        "type_name",
    )

    def __init__(
        self,
        topic: str,
        type_name: str,
        msg: dict[str, Any],
        stamp_ns: int,
        registry: TypeRegistry,
        cdr: bytes | None = None,
        *,
        size_hint: int | None = None,
        cdr_bytes: int | None = None,
        has_float32: bool | None = None,
    ) -> None:
        self.topic = topic
        self.type_name = type_name
        self.msg = msg
        self.stamp_ns = stamp_ns
        self.registry = registry
        self.cdr = cdr
        self.cdr_bytes = cdr_bytes
        self.size_hint = payload_bytes(msg) if size_hint is None else size_hint
        self._frames: dict[tuple[str, str] | tuple[str, str, float], WireFrame] = {}
        self._lock: threading.RLock | None = None  # made when first needed (`_locked`)
        self._reducer: CloudReducer | None = None
        self._has_float32 = has_float32

    def frame(self, encoding: str, topic: str) -> WireFrame:
        """The `publish` frame for `encoding` naming the topic as `topic` (thread-safe)."""
        key = (encoding, topic)
        cached = self._frames.get(key)
        if cached is not None:
            return cached
        if self.size_hint < UNLOCKED_ENCODE_BYTES:
            # Cheaper than a lock: two threads racing here encode a small frame twice, and
            # both get the first one stored.
            return self._frames.setdefault(key, self._encode(encoding, topic))
        with self._locked():
            cached = self._frames.get(key)
            if cached is None:
                cached = self._encode(encoding, topic)
                self._frames[key] = cached
        return cached

    def _locked(self) -> threading.RLock:
        """The message's lock (reentrant: png re-enters for the JSON frame), made on first use:
        most small messages never need one."""
        lock = self._lock
        if lock is None:
            with _MAKING_LOCKS:
                if self._lock is None:
                    self._lock = threading.RLock()
                lock = self._lock
        return lock

    def serialized(self) -> bytes:
        """The CDR bytes (with their 4-byte header), computed once and shared by cbor-raw and
        every other CDR speaker (thread-safe)."""
        if self.cdr is None:
            with self._locked():
                if self.cdr is None:
                    self.cdr = to_cdr(self.registry, self.type_name, self.msg)
        return self.cdr

    def reducer(self) -> CloudReducer:
        """The message's point-cloud reductions, shared by its subscribers (thread-safe)."""
        with self._locked():
            if self._reducer is None:
                self._reducer = CloudReducer(self.msg)
            return self._reducer

    def reduced_frame(self, encoding: str, topic: str, voxel_size_m: float) -> WireFrame:
        """The `publish` frame of the cloud thinned to one point per voxel (cbor or JSON;
        png and cbor-raw clients get JSON and cbor)."""
        key = (encoding, topic, voxel_size_m)
        cached = self._frames.get(key)
        if cached is not None:
            return cached
        msg, reduction = self.reducer().reduced(voxel_size_m)
        said = reduction.as_field()
        if encoding in (CBOR, CBOR_RAW):
            frame = WireFrame(publish_cbor(topic, msg, said), text=False, reduction=reduction)
        else:
            frame = WireFrame(publish_json(topic, msg, said), text=True, reduction=reduction)
        with self._locked():
            return self._frames.setdefault(key, frame)

    def _encode(self, encoding: str, topic: str) -> WireFrame:
        if encoding == CBOR:
            return WireFrame(publish_cbor(topic, self.msg), text=False)
        if encoding == CBOR_RAW:
            return WireFrame(publish_cbor_raw(topic, self.serialized(), self.stamp_ns), text=False)
        if encoding == PNG:
            return WireFrame(encode_png_op(self.frame(JSON, topic).data), text=True)
        return WireFrame(publish_json(topic, self.msg, widen=self._widens()), text=True)

    def _widens(self) -> bool:
        """Whether the message may hold float32 arrays, which JSON must widen (its type says)."""
        if self._has_float32 is None:
            try:
                self._has_float32 = self.registry.message(self.type_name).has_float32_sequence
            except SchemaError:
                self._has_float32 = True
        return self._has_float32


# Not frozen, like `bridge.effects.Send`: one per message and subscriber; treat as immutable.
# Compiled (`schemas.runtime.native`), it still takes a Python subclass (`FoxgloveDelivery`).
@mypyc_attr(allow_interpreted_subclasses=True)
@dataclass(slots=True)
class Delivery:
    """A topic message for one client: its topic spelling, chosen encoding and, for a point
    cloud, the reduction its subscription asked for (`bridge.reduction`)."""

    message: TopicMessage
    topic: str
    encoding: str
    reduce: ReduceRequest | None = None

    @property
    def size_hint(self) -> int:
        return self.message.size_hint

    @property
    def message_id(self) -> Any:
        return None

    def frame(self, link_bytes_per_s: float | None = None) -> WireFrame:
        """The frame for this client; an "auto" reduction sizes the cloud to
        `link_bytes_per_s`, the client's measured goodput (None: unmeasured)."""
        if self.reduce is None:
            return self.message.frame(self.encoding, self.topic)
        reducer = self.message.reducer()
        step = int(self.message.msg.get("point_step", 0) or 0)
        voxel_m = reducer.voxel_for(self.reduce, budget_for_link(link_bytes_per_s, step))
        if voxel_m is None:
            return self.message.frame(self.encoding, self.topic)
        return self.message.reduced_frame(self.encoding, self.topic, voxel_m)


@dataclass(frozen=True)
class ControlMessage:
    """A small JSON op for one client (service_response, call_service, action ops, status).

    Its frame is encoded once and kept: the edge measures it when queueing (the client's
    reply budget, `bridge.reply_budget`) and sends the same bytes later.
    """

    payload: dict[str, Any]

    @property
    def size_hint(self) -> int:
        return payload_bytes(self.payload)

    @property
    def message_id(self) -> Any:
        return self.payload.get("id")

    def frame(self, link_bytes_per_s: float | None = None) -> WireFrame:
        return self.wire

    @cached_property
    def wire(self) -> WireFrame:
        return WireFrame(codec_json.dumps(self.payload), text=True)


@dataclass(slots=True)  # (not frozen, as `Delivery`: one per message)
class RawFrame:
    """A frame built by another protocol's translator (Foxglove): sent as it is, never dropped
    unless given a drop key."""

    wire: WireFrame

    @property
    def size_hint(self) -> int:
        return len(self.wire.data)

    @property
    def message_id(self) -> Any:
        return None

    def frame(self, link_bytes_per_s: float | None = None) -> WireFrame:
        return self.wire


Outgoing = Delivery | ControlMessage | RawFrame


def render(
    item: Outgoing,
    fragment_size: int | None,
    fallback_id: str,
    link_bytes_per_s: float | None = None,
) -> list[WireFrame]:
    """The frames that carry `item`, split into `fragment` ops when longer than the size.

    `fragment_size` counts characters of the JSON text (ASCII, so bytes), or bytes of a CBOR
    frame: rosbridge never fragments binary frames (protocol §2.10), riverbridge does when a
    CBOR subscriber asks for it, into binary `fragment` ops whose `data` is a byte string
    (docs/bridge.md, "Over a thin link"). Fragments carry the message's own id, else
    `fallback_id`, and an integer `total`. `link_bytes_per_s` (the client's goodput) sizes an
    "auto" point-cloud reduction; the first frame carries what was done.
    """
    frame = item.frame(link_bytes_per_s)
    if fragment_size is None or len(frame.data) <= fragment_size:
        return [frame]
    message_id = item.message_id
    fragment_id = fallback_id if message_id is None else message_id
    if not frame.text:
        pieces = fragments_cbor(frame.data, fragment_size, fragment_id)
    else:
        pieces = fragments_json(frame.data.decode("ascii"), fragment_size, fragment_id)
    frames = [WireFrame(piece, text=frame.text) for piece in pieces]
    frames[0] = WireFrame(frames[0].data, frame.text, frame.reduction)
    return frames
