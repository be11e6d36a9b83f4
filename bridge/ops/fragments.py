"""Inbound `fragment` ops: reassemble by id and num, expire after the fragment timeout.

Pieces are joined sorted by `num` (the reference joins in arrival order, protocol §2.10);
`total` may be an int or the reference's float (the model floors it). A list that waits
longer than `fragment_timeout_s` is discarded with a log line. All of a client's incomplete lists
together may hold at most the inbound frame limit; past it the client is closed with 1009,
as for one oversized frame, so fragments cannot be used to get around the limit.
"""

from __future__ import annotations

from bridge.context import Context
from bridge.errors import OpFailure
from bridge.ops import route
from bridge.session import ClientSession, FragmentBuffer, StatusLevel
from schemas.ops import Fragment

NS_PER_S = 1_000_000_000
MESSAGE_TOO_BIG = 1009  # RFC 6455 close code, as websockets uses for an oversized frame


def handle_fragment(ctx: Context, session: ClientSession, op: Fragment) -> None:
    key, total = op.id, op.total
    if not isinstance(op.data, str):
        raise OpFailure("fragment data must be text (a slice of a JSON op)")
    if not 0 <= op.num < total:
        raise OpFailure(f"fragment num {op.num!r} outside 0..{total - 1}")
    buffer = session.fragments.get(key)
    if buffer is None:
        expires = ctx.now_ns + int(ctx.state.config.fragment_timeout_s * NS_PER_S)
        buffer = session.fragments[key] = FragmentBuffer(total, expires)
        ctx.schedule(("fragment", session.client_id, key), expires)
    elif buffer.total != total:
        raise OpFailure(f"fragment total {total} differs from the first fragment's {buffer.total}")
    if op.num in buffer.pieces:
        ctx.problem(
            session, "fragment", key, f"duplicate fragment {op.num} ignored", StatusLevel.WARNING
        )
        return
    buffer.pieces[op.num] = op.data
    buffer.size_chars += len(op.data)
    if session.fragment_chars() > ctx.state.config.max_message_size:
        session.fragments.clear()
        ctx.close(session.client_id, MESSAGE_TOO_BIG, "fragmented messages exceed the limit")
        raise OpFailure("fragmented messages exceed the message size limit; closing")
    if len(buffer.pieces) == total:
        del session.fragments[key]
        ctx.reassembled.append("".join(buffer.pieces[i] for i in range(total)))


def on_fragment_deadline(ctx: Context, client_id: int, key: str | int) -> None:
    """Drop a fragment list that did not complete within the timeout."""
    session = ctx.state.sessions.get(client_id)
    buffer = session.fragments.get(key) if session is not None else None
    if session is None or buffer is None or buffer.expires_at_ns > ctx.now_ns:
        return
    del session.fragments[key]
    ctx.problem(
        session,
        "fragment",
        key,
        f"discarded after {ctx.state.config.fragment_timeout_s:g} s with "
        f"{len(buffer.pieces)} of {buffer.total} fragments",
    )


ROUTES = (route(Fragment, handle_fragment),)
