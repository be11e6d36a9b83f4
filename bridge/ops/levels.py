"""`set_level`: opt in to `status` ops (protocol §1.5). Without it a client never gets one."""

from __future__ import annotations

from typing import Any

from bridge.context import Context
from bridge.errors import OpFailure
from bridge.session import ClientSession, StatusLevel


def handle_set_level(ctx: Context, session: ClientSession, op: Any) -> None:
    level = op.level.lower() if isinstance(op.level, str) else None
    try:
        session.status_level = StatusLevel[(level or "").upper()]
    except KeyError as exc:
        raise OpFailure(f"level must be info, warning, error or none, got {op.level!r}") from exc


HANDLERS = {"set_level": handle_set_level}
