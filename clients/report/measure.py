"""Measuring one window of a running stack through the bridge, as an ordinary client.

:func:`measure` subscribes to ``/riverbridge/trace`` and ``/riverbridge/process_stats``,
navigation's outputs and the simulator's truth and configuration, waits out the warm-up,
reads the kernel's socket and loopback counters at the window's start and end, asks the
bridge's ``/riverbridge/stats``, and hands what it saw to :func:`clients.report.build.build_run`.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import time
import urllib.parse
from pathlib import Path
from typing import Any, TextIO

from clients.client import RosbridgeClient
from clients.report.build import (
    QUALITY_TOPICS,
    Observations,
    build_run,
    describe_sample,
    vessel_hull_m,
)
from clients.report.journeys import spans_of_batch
from clients.report.mission import AutopilotSeen
from clients.report.results import Machine, Run
from clients.report.shore import ShoreWatch
from clients.report.sockets import SS_COMMAND, SocketBytes, parse_ss
from clients.report.stats import loopback_tx_bytes
from clients.subscription import Subscription
from schemas.catalogue import TOPICS
from schemas.tracing import (
    NS_PER_S,
    STATS_SERVICE,
    STATS_SERVICE_TYPE,
    STATS_TOPIC,
    STATS_TYPE,
    TRACE_TOPIC,
    TRACE_TYPE,
    header_stamp_ns,
)

# Spans of a message arrive up to ~1 s (batch period) after its last stage; a LIDAR scan's
# last stage ends ~0.2 s after capture. Wait this long after the window before summarising.
TAIL_S = 2.5
SAMPLE_TYPES = {t.name: t.type for t in TOPICS.values() if t.thesis_sensor}
SIM_CONFIG = TOPICS["sim_config"].pair
# What the mission figures read (clients.report.mission): the vessel's track (10 Hz is plenty
# for clearance and cross-track), the route, the scene's objects and the simulator's counters.
AUTOPILOT_TOPICS: dict[str, dict[str, Any]] = {
    "odom": {"maxsize": 100_000, "throttle_rate": 100},
    "guidance_path": {"maxsize": 1},
    "ground_truth": {"maxsize": 1},
    "sim_status": {"maxsize": 10_000},
}


class Progress:
    """A progress bar on ``stream``: ``\\r`` updates on a TTY, a line every 5 s otherwise."""

    def __init__(self, stream: TextIO, width: int = 30) -> None:
        self._stream, self._width = stream, width
        self._tty = stream.isatty()
        self._last_line_s = -math.inf

    def update(self, label: str, done_s: float, total_s: float) -> None:
        fraction = min(1.0, done_s / total_s) if total_s > 0 else 1.0
        if self._tty:
            filled = int(fraction * self._width)
            bar = "#" * filled + "-" * (self._width - filled)
            self._stream.write(f"\r{label} [{bar}] {done_s:5.1f}/{total_s:.0f} s")
        elif done_s - self._last_line_s >= 5.0 or fraction >= 1.0:
            self._last_line_s = done_s
            self._stream.write(f"{label}: {done_s:.0f}/{total_s:.0f} s\n")
        self._stream.flush()

    def message(self, text: str) -> None:
        self._stream.write(("\r\x1b[K" if self._tty else "") + text + "\n")
        self._stream.flush()


def read_loopback() -> int | None:
    try:
        return loopback_tx_bytes(Path("/proc/net/dev").read_text())
    except OSError:
        return None


async def read_sockets() -> list[SocketBytes] | None:
    """The kernel's byte counters of every established TCP socket (``ss``), None without
    ``ss`` (iproute2)."""
    try:
        process = await asyncio.create_subprocess_exec(
            *SS_COMMAND, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL
        )
    except OSError:
        return None
    out, _ = await process.communicate()
    return parse_ss(out.decode(errors="replace")) if process.returncode == 0 else None


async def sample_payloads(client: RosbridgeClient, timeout_s: float = 3.0) -> dict[str, str]:
    """One message of each sensor topic, described; after the window, so it costs nothing
    during the measurement."""
    samples: dict[str, str] = {}
    for topic, type_name in SAMPLE_TYPES.items():
        sub = await client.subscribe(topic, type_name, maxsize=1)
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_s):
                samples[topic] = describe_sample(topic, (await sub.get()).msg)
        await sub.unsubscribe()
    return samples


def _in_window(
    messages: list[dict[str, Any]], start_ns: int, end_ns: float
) -> list[dict[str, Any]]:
    return [m for m in messages if start_ns <= (header_stamp_ns(m) or 0) <= end_ns]


async def measure(
    url: str,
    encoding: str,
    duration_s: float,
    warmup_s: float,
    progress: Progress,
    profile: str | None = None,
    link: str | None = None,
) -> Run:
    """Read the telemetry of the stack at ``url`` for ``duration_s`` after ``warmup_s``; with
    ``link`` (a `clients.linkemu` profile), also the IMU and LIDAR ashore (`shore.py`)."""
    async with contextlib.AsyncExitStack() as stack:
        shore = None
        if link is not None:
            parts = urllib.parse.urlsplit(url)
            bridge = (parts.hostname or "127.0.0.1", parts.port or 9090)
            shore = await stack.enter_async_context(ShoreWatch(link, bridge))
        return await _measure(url, encoding, duration_s, warmup_s, progress, profile, shore)


async def _measure(
    url: str,
    encoding: str,
    duration_s: float,
    warmup_s: float,
    progress: Progress,
    profile: str | None,
    shore: ShoreWatch | None,
) -> Run:
    label = encoding if profile in (None, "default") else f"{profile}/{encoding}"
    async with RosbridgeClient(
        url, encoding="cbor", name="report", reconnect=False, connect_timeout=3.0
    ) as client:
        trace = await client.subscribe(TRACE_TOPIC, TRACE_TYPE, maxsize=100_000)
        stats = await client.subscribe(STATS_TOPIC, STATS_TYPE, maxsize=100_000)
        quality = {
            key: await client.subscribe(topic, type_name, maxsize=1000)
            for key, (topic, type_name) in QUALITY_TOPICS.items()
        }
        sim_config = await client.subscribe(*SIM_CONFIG, maxsize=1)
        autopilot = {
            key: await client.subscribe(*TOPICS[key].pair, **options)
            for key, options in AUTOPILOT_TOPICS.items()
        }
        await _wait(warmup_s, f"{label} warm-up", progress)
        for sub in (*quality.values(), autopilot["odom"], autopilot["sim_status"]):
            _drain(sub)  # judge only what falls in the window
        start_ns, lo_start, ss_start = time.time_ns(), read_loopback(), await read_sockets()
        await _wait(duration_s, f"{label} measuring", progress)
        end_ns, lo_end, ss_end = time.time_ns(), read_loopback(), await read_sockets()
        load = os.getloadavg()
        await _wait(TAIL_S, f"{label} collecting", progress)
        bridge_stats = await client.call_service(STATS_SERVICE, type=STATS_SERVICE_TYPE)
        spans = [
            s
            for batch in _drain(trace)
            for s in spans_of_batch(batch)
            if start_ns <= s.stamp_ns <= end_ns
        ]
        config = _drain(sim_config)
        watched = {key: _drain(sub) for key, sub in autopilot.items()}
        seen = Observations(
            encoding=encoding,
            duration_s=(end_ns - start_ns) / NS_PER_S,
            spans=spans,
            process_stats=_in_window(_drain(stats), start_ns, end_ns + TAIL_S * NS_PER_S),
            bridge_stats=bridge_stats,
            judged={key: _in_window(_drain(sub), start_ns, end_ns) for key, sub in quality.items()},
            sim_config=config[-1] if config else None,
            samples=await sample_payloads(client),
            loopback_bytes=(
                lo_end - lo_start if lo_start is not None and lo_end is not None else None
            ),
            sockets_before=ss_start,
            sockets_after=ss_end,
            report_pid=os.getpid(),
            machine=Machine(os.cpu_count(), load),
            profile=profile,
            autopilot=autopilot_seen(watched, start_ns, end_ns, config[-1] if config else None),
            shore_link=shore.summary(start_ns, end_ns) if shore is not None else None,
        )
    return build_run(seen)


def autopilot_seen(
    watched: dict[str, list[dict[str, Any]]],
    start_ns: int,
    end_ns: int,
    sim_config: dict[str, Any] | None,
) -> AutopilotSeen | None:
    """What the window saw of an autopilot; None when no guidance published its route."""
    if not watched["guidance_path"]:
        return None
    truth = watched["ground_truth"]
    return AutopilotSeen(
        odometry=_in_window(watched["odom"], start_ns, end_ns),
        path=watched["guidance_path"][-1],
        ground_truth=truth[-1] if truth else None,
        status=_in_window(watched["sim_status"], start_ns, end_ns),
        hull_m=vessel_hull_m(sim_config),
    )


def _drain(sub: Subscription) -> list[dict[str, Any]]:
    items = []
    while (item := sub.get_nowait()) is not None:
        items.append(item.msg)
    return items


async def _wait(seconds: float, label: str, progress: Progress) -> None:
    loop = asyncio.get_running_loop()
    start = loop.time()
    while (done := loop.time() - start) < seconds:
        progress.update(label, done, seconds)
        await asyncio.sleep(min(0.5, seconds - done))
    progress.update(label, seconds, seconds)
    progress.message(f"{label}: done")
