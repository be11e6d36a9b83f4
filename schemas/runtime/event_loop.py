"""Which asyncio event loop a riverbridge process runs on: the standard one, or uvloop when
`RIVERBRIDGE_EVENT_LOOP=uvloop` asks for it (install the `uvloop` extra).

uvloop (libuv) runs the same asyncio code: websockets, TLS, timers and executors all work on
it unchanged (every real client in tests/compat passed against a bridge on it, 2026-11-26).
It is not the default because it does not win where this project is judged
(`benchmarks/relay.py --uvloop`, the bridge on both loops in one run). First measured
2026-11-26: it halved a service round trip's tail (p95 3.3 vs 8.6 ms, load 7-32) and moved
small messages at the same rate, but a full CBOR scan fanned out to 16 subscribers arrived
later than on asyncio's loop (scan p50 1.79x the bare relay's against 1.15x, load 5-11).
Measured again after the bridge stopped going through websockets' per-frame machinery (issue
21, three quiet sittings, medians of 3 interleaved runs, ratios to the bare relay, uvloop /
asyncio): the fan-out no longer suffers (scan p50 0.97-1.03x against 0.88-1.06x, IMU p99
0.30-0.33x against 0.28-0.36x), and small messages split both ways: burst JSON 0.82-0.97x
against 0.78-0.83x, burst CBOR 0.63-0.95x against 0.68-0.84x, sustained JSON 0.79-0.82x
against 0.69-0.85x, sustained CBOR 0.72-0.79x against 0.67-0.85x. No consistent win, so the
standard loop stays the default and uvloop a choice.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
from collections.abc import Callable, Coroutine, Mapping, Sequence
from typing import Any, TypeVar

T = TypeVar("T")

#: Names the event loop: "asyncio" (the standard one, the default) or "uvloop".
EVENT_LOOP_ENV = "RIVERBRIDGE_EVENT_LOOP"
EVENT_LOOPS = ("uvloop", "asyncio")

LoopFactory = Callable[[], asyncio.AbstractEventLoop]


class EventLoopChoiceError(ValueError):
    """`RIVERBRIDGE_EVENT_LOOP` names no known loop."""


def chosen_loop(environ: Mapping[str, str] | None = None) -> str:
    """The loop this process should run: `RIVERBRIDGE_EVENT_LOOP` if set, else asyncio.
    Raises EventLoopChoiceError for an unknown name, or for "uvloop" when it is not
    installed."""
    env = os.environ if environ is None else environ
    wanted = env.get(EVENT_LOOP_ENV, "").strip().lower() or "asyncio"
    if wanted not in EVENT_LOOPS:
        raise EventLoopChoiceError(
            f"{EVENT_LOOP_ENV}={wanted!r}: expected one of {', '.join(EVENT_LOOPS)}"
        )
    if wanted == "uvloop" and _uvloop_factory() is None:
        raise EventLoopChoiceError(
            f"{EVENT_LOOP_ENV}=uvloop, but uvloop is not installed (pip install uvloop)"
        )
    return wanted


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


async def cancel_and_wait(tasks: Sequence[asyncio.Task[Any]]) -> None:
    """Cancel `tasks`, then wait for each to end: how a process stops what it started."""
    for task in tasks:
        task.cancel()
    for task in tasks:
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def run_until_set(stop: asyncio.Event, tasks: Sequence[asyncio.Task[Any]]) -> None:
    """A node's life: `tasks` run until `stop` is set (or this is cancelled), then end."""
    try:
        await stop.wait()
    finally:
        await cancel_and_wait(tasks)
