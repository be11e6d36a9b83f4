"""`set_level`: opt in to `status` ops (protocol §1.5). Without it a client never gets one."""

from __future__ import annotations

from bridge.context import Context
from bridge.ops import route
from bridge.session import ClientSession, StatusLevel
from schemas.ops import SetLevel


def handle_set_level(ctx: Context, session: ClientSession, op: SetLevel) -> None:
    session.status_level = StatusLevel[op.level.upper()]  # the model allows only the four


ROUTES = (route(SetLevel, handle_set_level),)
