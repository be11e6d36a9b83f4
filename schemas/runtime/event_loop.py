"""Which asyncio event loop a riverbridge process runs on: uvloop where it is installed, else
the standard one; `RIVERBRIDGE_EVENT_LOOP=asyncio` keeps the standard loop anyway.

uvloop (libuv) runs the same asyncio code: websockets, TLS, timers and executors all work on
it unchanged. It cuts the loop's own cost per callback and per socket write, which is most of
what a small relayed message costs beyond decoding and routing, and its transports keep a
reference to a written buffer instead of copying what the kernel did not take at once (one
scan fanned out to many sockets is not copied per socket). Measured with
`benchmarks/relay.py --pure` (the bridge on both loops in one run).
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Coroutine, Mapping
from typing import Any, TypeVar

T = TypeVar("T")

#: Names the event loop: "uvloop" (the default where installed) or "asyncio" (the standard one).
EVENT_LOOP_ENV = "RIVERBRIDGE_EVENT_LOOP"
EVENT_LOOPS = ("uvloop", "asyncio")

LoopFactory = Callable[[], asyncio.AbstractEventLoop]


class EventLoopChoiceError(ValueError):
    """`RIVERBRIDGE_EVENT_LOOP` names no known loop."""


def chosen_loop(environ: Mapping[str, str] | None = None) -> str:
    """The loop this process should run: `RIVERBRIDGE_EVENT_LOOP` if set, else uvloop when it
    is importable, else asyncio. Raises EventLoopChoiceError for an unknown name, or for
    "uvloop" when it is not installed."""
    env = os.environ if environ is None else environ
    wanted = env.get(EVENT_LOOP_ENV, "").strip().lower()
    if wanted and wanted not in EVENT_LOOPS:
        raise EventLoopChoiceError(
            f"{EVENT_LOOP_ENV}={wanted!r}: expected one of {', '.join(EVENT_LOOPS)}"
        )
    if wanted == "asyncio":
        return "asyncio"
    if _uvloop_factory() is not None:
        return "uvloop"
    if wanted == "uvloop":
        raise EventLoopChoiceError(f"{EVENT_LOOP_ENV}=uvloop, but uvloop is not installed")
    return "asyncio"


def loop_factory(name: str) -> LoopFactory | None:
    """The factory of loop `name` for `asyncio.Runner` (None: the standard loop)."""
    return _uvloop_factory() if name == "uvloop" else None


def run(main: Coroutine[Any, Any, T], name: str | None = None) -> T:
    """`asyncio.run(main)` on loop `name` (default: `chosen_loop()`)."""
    with asyncio.Runner(loop_factory=loop_factory(name or chosen_loop())) as runner:
        return runner.run(main)


def _uvloop_factory() -> LoopFactory | None:
    try:
        import uvloop
    except ImportError:
        return None
    factory: LoopFactory = uvloop.new_event_loop
    return factory


def running_loop_name() -> str:
    """The running loop's name, "uvloop" or "asyncio" (for log lines and benchmarks)."""
    module = type(asyncio.get_running_loop()).__module__
    return "uvloop" if module.startswith("uvloop") else "asyncio"
