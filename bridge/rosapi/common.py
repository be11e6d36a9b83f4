"""Shared pieces of the rosapi service tables."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from bridge.context import Context
from bridge.errors import RosapiError

RosapiHandler = Callable[[Context, dict[str, Any]], dict[str, Any]]


@dataclass(frozen=True)
class RosapiService:
    """One rosapi service: its `rosapi_msgs/srv/*` type and its handler."""

    type_name: str
    handler: RosapiHandler


def text_arg(request: dict[str, Any], field: str) -> str:
    """A string request field; absent means empty, other types are refused."""
    value = request.get(field, "")
    if not isinstance(value, str):
        raise RosapiError(f"field {field} must be a string, got {type(value).__name__}")
    return value


def table(prefix: str, entries: dict[str, tuple[str, RosapiHandler]]) -> dict[str, RosapiService]:
    """`{"topics": ("Topics", fn)}` -> `{"/rosapi/topics": RosapiService(...)}`."""
    return {
        f"{prefix}/{name}": RosapiService(f"rosapi_msgs/srv/{srv}", handler)
        for name, (srv, handler) in entries.items()
    }
