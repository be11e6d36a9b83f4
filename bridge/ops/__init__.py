"""Op handlers, one module per op family, merged into one dispatch table keyed by op."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from bridge.context import Context
from bridge.session import ClientSession

Handler = Callable[[Context, ClientSession, Any], None]


def merge_tables(*tables: Mapping[str, Handler]) -> dict[str, Handler]:
    """One table from several families; an op claimed twice is a programming error."""
    merged: dict[str, Handler] = {}
    for table in tables:
        clash = merged.keys() & table.keys()
        if clash:
            raise ValueError(f"ops handled twice: {sorted(clash)}")
        merged.update(table)
    return merged
