"""``riverbridge report``: run the stack (or attach to one) and report where time and bytes go.

For each payload profile and encoding (``--profile default,thesis --encoding cbor,json`` runs
the four in turn) it starts bridge, simulator and navigation through
:class:`clients.stack.launcher.Supervisor`, lets them warm up, then reads ``/riverbridge/trace`` and
``/riverbridge/process_stats`` for ``--duration`` seconds as an ordinary rosbridge client,
together with navigation's outputs and the simulator's ground truth; it asks the bridge's
``/riverbridge/stats`` and reads the kernel's byte counters of the stack's sockets and of
``lo`` at the window's start and end. It prints per topic rate, bytes, the mean and
p50/p90/p99/max per stage beside the thesis's figures, the network overhead the thesis's way,
and navigation's detection quality (stdout; docs/report.md, docs/quality.md), shows progress on
stderr, and can write ``--json`` and ``--plots``. ``--record FILE`` also records every topic
into an MCAP file; ``--replay FILE`` measures the bridge and navigation on a recording, with a
player (clients.recording) in the simulator's place (docs/recording.md).

Exit codes: 0 report written; 1 the stack failed or nothing was measured; 2 bad options.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import logging
import math
import os
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from clients.client import RosbridgeClient
from clients.errors import RosbridgeError
from clients.recording.components import (
    player_component,
    record_path,
    recorder_component,
    recorder_process,
)
from clients.recording.play_cli import recording_file
from clients.recording.reading import recorded_topics
from clients.recording.record_cli import output_file
from clients.report.plots import write_plots
from clients.report.quality import lidar_quality, pair_by_stamp, radar_quality
from clients.report.sockets import SS_COMMAND, SocketBytes, parse_ss, window_traffic
from clients.report.stats import (
    SENSOR_TOPICS,
    SpanRecord,
    by_topic,
    hosts_of,
    journeys,
    loopback_tx_bytes,
    network_summary,
    process_summary,
    spans_of_batch,
    stage_values,
    topic_summary,
)
from clients.report.text import render_comparison, render_run, run_label
from clients.report.thesis import thesis_comparison
from clients.stack.launcher import (
    SIMULATOR_TOPICS,
    LaunchConfig,
    PrefixedOutput,
    Supervisor,
    stack_components,
)
from clients.stack.up_cli import positive_seconds
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

log = logging.getLogger(__name__)

ENCODINGS = ("json", "cbor")
# Spans of a message arrive up to ~1 s (batch period) after its last stage; a LIDAR scan's
# last stage ends ~0.2 s after capture. Wait this long after the window before summarising.
TAIL_S = 2.5
SAMPLE_TYPES = {t.name: t.type for t in TOPICS.values() if t.thesis_sensor}
PROFILES = ("default", "thesis")  # simulator payload profiles (simulator.config.PROFILES)
STACK_PROCESSES = ("bridge", "simulator", "navigation")
# What the detection quality reads (docs/quality.md): the truth and navigation's outputs.
QUALITY_TOPICS = {"lidar_truth": TOPICS["lidar_truth"].pair,
                  "radar_truth": TOPICS["radar_truth"].pair,
                  "boxes": TOPICS["boxes"].pair, "radar": TOPICS["radar_detections"].pair}
SIM_CONFIG = TOPICS["sim_config"].pair


# --------------------------------------------------------------------------- progress


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


# --------------------------------------------------------------------------- measuring


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
            *SS_COMMAND, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.DEVNULL)
    except OSError:
        return None
    out, _ = await process.communicate()
    return parse_ss(out.decode(errors="replace")) if process.returncode == 0 else None


def stack_sockets(before: list[SocketBytes] | None, after: list[SocketBytes] | None,
                  processes: dict[str, dict[str, Any]]) -> dict[str, Any] | None:
    """What the stack's processes' sockets sent in the window (clients.report.sockets)."""
    if before is None or after is None:
        return None
    pids = {int(p["pid"]): name for name, p in processes.items() if name in STACK_PROCESSES}
    return window_traffic(before, after, pids, [os.getpid()])


def describe_sample(topic: str, msg: dict[str, Any]) -> str:
    """The payload of one sensor message in words (points per scan, cells, bytes)."""
    if topic == TOPICS["lidar"].name:
        return f"{int(msg['width']) * int(msg['height']):,} points x {msg['point_step']} B"
    if topic == TOPICS["radar"].name:
        return f"{msg['num_beams']} beams x {msg['num_cells']} cells float32"
    if topic == TOPICS["camera"].name:
        return f"{msg['format']} {len(msg['data']):,} B"
    return "one sample"


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


async def measure(url: str, encoding: str, duration_s: float, warmup_s: float,
                  progress: Progress, profile: str | None = None) -> dict[str, Any]:
    """Read the telemetry of the stack at ``url`` for ``duration_s`` after ``warmup_s``."""
    label = encoding if profile in (None, "default") else f"{profile}/{encoding}"
    async with RosbridgeClient(url, encoding="cbor", name="report", reconnect=False,
                               connect_timeout=3.0) as client:
        trace = await client.subscribe(TRACE_TOPIC, TRACE_TYPE, maxsize=100_000)
        stats = await client.subscribe(STATS_TOPIC, STATS_TYPE, maxsize=100_000)
        quality = {key: await client.subscribe(topic, type_name, maxsize=1000)
                   for key, (topic, type_name) in QUALITY_TOPICS.items()}
        sim_config = await client.subscribe(*SIM_CONFIG, maxsize=1)
        await _wait(warmup_s, f"{label} warm-up", progress)
        for sub in quality.values():
            _drain(sub)  # judge only what falls in the window
        start_ns, lo_start, ss_start = time.time_ns(), read_loopback(), await read_sockets()
        await _wait(duration_s, f"{label} measuring", progress)
        end_ns, lo_end, ss_end = time.time_ns(), read_loopback(), await read_sockets()
        load = os.getloadavg()
        await _wait(TAIL_S, f"{label} collecting", progress)
        bridge_stats = await client.call_service(STATS_SERVICE, type=STATS_SERVICE_TYPE)
        spans = [s for batch in _drain(trace) for s in spans_of_batch(batch)
                 if start_ns <= s.stamp_ns <= end_ns]
        process_stats = [m for m in _drain(stats)
                         if start_ns <= (header_stamp_ns(m) or 0) <= end_ns + TAIL_S * NS_PER_S]
        judged = {key: [m for m in _drain(sub) if start_ns <= (header_stamp_ns(m) or 0) <= end_ns]
                  for key, sub in quality.items()}
        config = _drain(sim_config)
        samples = await sample_payloads(client)
    lo_bytes = lo_end - lo_start if lo_start is not None and lo_end is not None else None
    run = build_run(encoding, spans, process_stats, bridge_stats, samples,
                    (end_ns - start_ns) / NS_PER_S, lo_bytes)
    run["network"] = network_summary(run["topics"], lo_bytes, run["duration_s"],
                                     stack_sockets(ss_start, ss_end, run["processes"]))
    run["machine"] = {"cpus": os.cpu_count(), "load_average_1_5_15": list(load)}
    run["detection_quality"] = detection_quality(judged)
    run.update(simulator_settings(config[-1] if config else None, profile))
    run["thesis_comparison"] = thesis_comparison(run)
    return run


def detection_quality(judged: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """Precision and recall of LIDAR boxes and radar targets (clients.report.quality)."""
    lidar = pair_by_stamp(judged["lidar_truth"], judged["boxes"])
    radar = pair_by_stamp(judged["radar_truth"], judged["radar"])
    quality: dict[str, Any] = {}
    if lidar:
        quality["lidar"] = lidar_quality(lidar)
    if radar:
        quality["radar"] = radar_quality(radar)
    return quality


def simulator_settings(config_msg: dict[str, Any] | None, profile: str | None) -> dict[str, Any]:
    """The profile and LIDAR water model the simulator ran with (its latched /sim/config)."""
    try:
        config = json.loads(config_msg["data"]) if config_msg else {}
    except (KeyError, TypeError, ValueError):
        config = {}
    lidar = config.get("lidar", {})
    return {"profile": config.get("profile", profile or "unknown"),
            "water_model": lidar.get("water_model", "unknown"),
            "point_fields": lidar.get("point_fields", "unknown")}


def build_run(encoding: str, spans: list[SpanRecord], process_stats: list[dict[str, Any]],
              bridge_stats: dict[str, Any], samples: dict[str, str], duration_s: float,
              loopback_bytes: int | None) -> dict[str, Any]:
    """Everything the report says about one run (JSON-ready but for NaNs)."""
    grouped = by_topic(journeys(spans))
    topics = {t: topic_summary(t, items, duration_s) for t, items in grouped.items()}
    return {"encoding": encoding, "duration_s": duration_s, "hosts": hosts_of(spans),
            "spans": len(spans), "topics": topics, "samples": samples,
            "processes": process_summary(process_stats),
            "network": network_summary(topics, loopback_bytes, duration_s),
            "bridge": bridge_stats,
            "_values": {t: stage_values(items) for t, items in grouped.items()}}


def _drain(sub: Any) -> list[dict[str, Any]]:
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


def profile_sim_config(profile: str, sim_config: Path | None, folder: Path) -> Path | None:
    """The simulator config for ``profile``: ``sim_config`` itself for the default profile,
    else a copy in ``folder`` that starts with ``profile = "..."`` (the file's own settings
    still win over the profile's, simulator.config)."""
    if profile == "default":
        return sim_config
    text = sim_config.read_text(encoding="utf-8") if sim_config else ""
    path = folder / f"sim-{profile}.toml"
    path.write_text(f'profile = "{profile}"\n' + text, encoding="utf-8")
    return path


async def run_stack(encoding: str, args: argparse.Namespace, progress: Progress,
                    log_stream: TextIO, profile: str = "default",
                    sim_config: Path | None = None) -> dict[str, Any]:
    """Start the stack with ``encoding`` and the simulator's ``sim_config``, measure it,
    stop it. Raises RuntimeError."""
    config = LaunchConfig(port=0, encoding=encoding, sim_config=sim_config,
                          nav_config=args.nav_config, startup_timeout_s=args.startup_timeout)
    stop = asyncio.Event()
    measuring: list[asyncio.Task[dict[str, Any]]] = []
    label = encoding if profile == "default" else f"{profile}/{encoding}"

    def on_ready(url: str) -> None:
        progress.message(f"{label}: stack ready at {url}")
        name = f"{encoding} replay" if args.replay is not None else encoding
        task = asyncio.create_task(measure(url, name, args.duration, args.warmup, progress,
                                           profile))
        task.add_done_callback(lambda _: stop.set())
        measuring.append(task)

    components = stack_components(config)
    if args.replay is not None:  # the recording's sensor topics in the simulator's place
        bridge, _simulator, navigation = components
        components = (bridge, player_component(args.replay, args.replay_topics), navigation)
    if args.record is not None:
        runs = len(args.encoding) * len(args.profile)
        components += (recorder_component(record_path(args.record, label.replace("/", "-"),
                                                      runs)),)
    progress.message(f"{label}: starting " + ", ".join(c.title for c in components))
    supervisor = Supervisor(components, config,
                            PrefixedOutput(log_stream, colour=False), on_ready=on_ready)
    status = await supervisor.run(stop)
    if not measuring:
        raise RuntimeError(f"the {label} stack did not start (exit status {status})")
    task = measuring[0]
    if not task.done():
        task.cancel()
        raise RuntimeError(f"the {label} stack stopped during the measurement")
    return task.result()


# --------------------------------------------------------------------------- output


def json_ready(value: Any) -> Any:
    """NaN and infinities become null (strict JSON); private keys (``_values``) are left out."""
    if isinstance(value, np.ndarray | np.generic):
        value = value.tolist()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items() if not str(k).startswith("_")}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    return value


# --------------------------------------------------------------------------- CLI


def _choices(allowed: tuple[str, ...]) -> Callable[[str], tuple[str, ...]]:
    """A comma-separated list of names from ``allowed``, for argparse."""
    def parse(text: str) -> tuple[str, ...]:
        names = tuple(name.strip() for name in text.split(",") if name.strip())
        unknown = [name for name in names if name not in allowed]
        if not names or unknown:
            raise argparse.ArgumentTypeError(f"choose from {', '.join(allowed)}, got {text!r}")
        return names
    return parse


_encodings = _choices(ENCODINGS)


def _existing_file(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    return path.resolve()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverbridge report", description="Run the stack (or attach to a running one) "
        "and report per topic and stage where time and bytes go, next to the thesis's figures.")
    parser.add_argument("--duration", type=positive_seconds, default=30.0, metavar="S",
                        help="seconds to measure per encoding (default %(default)s)")
    parser.add_argument("--warmup", type=positive_seconds, default=5.0, metavar="S",
                        help="seconds to let the stack settle first (default %(default)s)")
    parser.add_argument("--encoding", type=_encodings, default=("cbor",), metavar="LIST",
                        help="comma-separated encodings to run in turn: json, cbor "
                        "(default cbor; ignored with --bridge)")
    parser.add_argument("--profile", type=_choices(PROFILES), default=("default",),
                        metavar="LIST", help="comma-separated simulator payload profiles to run "
                        "in turn: default, thesis (the thesis's LIDAR payload, docs/report.md; "
                        "default: default; ignored with --bridge)")
    parser.add_argument("--bridge", metavar="URL",
                        help="attach to the running stack at ws://HOST:PORT instead")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write everything as JSON")
    parser.add_argument("--plots", type=Path, metavar="DIR", help="write PNG box plots here")
    parser.add_argument("--sim-config", type=_existing_file, metavar="FILE")
    parser.add_argument("--nav-config", type=_existing_file, metavar="FILE")
    parser.add_argument("--startup-timeout", type=positive_seconds, default=120.0, metavar="S")
    parser.add_argument("--log", type=Path, metavar="FILE",
                        help="where the stack's logs go (default: a file in the temp folder)")
    parser.add_argument("--record", type=output_file, metavar="FILE.mcap",
                        help="also record every topic into this MCAP file (one file per "
                        "encoding, FILE.<encoding>.mcap, when several run)")
    parser.add_argument("--replay", type=recording_file, metavar="FILE.mcap",
                        help="measure on a recording: bridge, navigation and a player of the "
                        "recording's sensor topics (looped), no simulator")
    return parser


def check_paths(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse unwritable outputs before spending minutes measuring (exit 2)."""
    if args.bridge is not None and not args.bridge.startswith(("ws://", "wss://")):
        parser.error(f"argument --bridge: not a ws:// URL: {args.bridge}")
    for option, path in (("--json", args.json), ("--log", args.log)):
        if path is not None and (path.is_dir() or not path.parent.is_dir()):
            parser.error(f"argument {option}: cannot write {path}")
    if args.sim_config is not None and "default" not in args.profile and _sets_profile(
            args.sim_config):
        parser.error(f"argument --profile: {args.sim_config} sets profile itself; drop one")
    if args.replay is not None:
        if args.bridge is not None:
            parser.error("argument --replay: starts its own stack; leave out --bridge")
        if tuple(args.profile) != ("default",):
            parser.error("argument --replay: the recording sets the payload; leave out "
                         "--profile")
        args.replay_topics = [t for t in SIMULATOR_TOPICS if t in recorded_topics(args.replay)]
        if not args.replay_topics:
            parser.error(f"argument --replay: {args.replay} has none of the simulator's "
                         f"topics ({', '.join(SIMULATOR_TOPICS)})")
    if args.plots is not None:
        try:
            args.plots.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            parser.error(f"argument --plots: cannot create {args.plots}: {exc.strerror}")


def _sets_profile(path: Path) -> bool:
    """Whether a TOML file sets the top-level ``profile`` (unreadable files: the simulator
    names the problem when it loads them)."""
    try:
        with path.open("rb") as stream:
            return "profile" in tomllib.load(stream)
    except (OSError, tomllib.TOMLDecodeError):
        return False


async def _run_all(args: argparse.Namespace, progress: Progress,
                   log_stream: TextIO) -> list[dict[str, Any]]:
    if args.bridge is not None:
        if args.record is None:
            return [await measure(args.bridge, "attached", args.duration, args.warmup,
                                  progress)]
        async with recorder_process(args.bridge, args.record):
            return [await measure(args.bridge, "attached", args.duration, args.warmup,
                                  progress)]
    runs = []
    with tempfile.TemporaryDirectory(prefix="riverbridge-report-") as folder:
        for profile in args.profile:
            sim_config = profile_sim_config(profile, args.sim_config, Path(folder))
            runs += [await run_stack(encoding, args, progress, log_stream, profile, sim_config)
                     for encoding in args.encoding]
    return runs


def main(argv: list[str] | None = None, *, stdout: TextIO | None = None,
         stderr: TextIO | None = None) -> int:
    out, err = stdout or sys.stdout, stderr or sys.stderr
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        check_paths(parser, args)
    except SystemExit as exc:
        return int(exc.code or 0)
    progress = Progress(err)
    log_path = args.log or Path(tempfile.gettempdir()) / "riverbridge-report.log"
    try:
        with open(log_path, "w", encoding="utf-8") as log_stream:
            runs = asyncio.run(_run_all(args, progress, log_stream))
    except (RuntimeError, RosbridgeError, OSError, TimeoutError) as exc:
        progress.message(f"riverbridge report: {exc} (stack logs: {log_path})")
        return 1
    return _emit(runs, args, out, progress)


def _emit(runs: list[dict[str, Any]], args: argparse.Namespace, out: TextIO,
          progress: Progress) -> int:
    write: Callable[[str], Any] = out.write
    if args.replay is not None:
        write(f"REPLAY of {args.replay}: {', '.join(args.replay_topics)} played from the "
              "recording (looped, header stamps shifted to capture time on today's clock); "
              "no simulator ran, so there is no generate stage.\n\n")
    for run in runs:
        write(render_run(run) + "\n\n")
    if len(runs) > 1:
        write(render_comparison(runs) + "\n")
    if args.json is not None:
        document = {"runs": json_ready(runs), "sensor_topics": list(SENSOR_TOPICS),
                    # one list over all runs, each row tagged with its run (docs/report.md)
                    "thesis_comparison": [{"run": run_label(run), **row} for run in runs
                                          for row in json_ready(run["thesis_comparison"])],
                    "replay": str(args.replay) if args.replay is not None else None}
        args.json.write_text(json.dumps(document, indent=1), encoding="utf-8")
        progress.message(f"wrote {args.json}")
    if args.plots is not None:
        for path in write_plots(runs, args.plots):
            log.debug("wrote %s", path)
        progress.message(f"wrote plots to {args.plots}")
    return 0 if any(run["spans"] for run in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
