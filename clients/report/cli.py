"""``riverbridge report``: run the stack (or attach to one) and report where time and bytes go.

For each payload profile and encoding (``--profile default,thesis --encoding cbor,json`` runs
the four in turn) it starts bridge, simulator and navigation through
:class:`clients.stack.launcher.Supervisor`, lets them warm up, then reads
``/riverbridge/trace`` and ``/riverbridge/process_stats`` for ``--duration`` seconds as an
ordinary rosbridge client (:mod:`clients.report.measure`),
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
import json
import logging
import sys
import tempfile
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO

from clients.errors import RosbridgeError
from clients.linkemu import PROFILES as LINK_PROFILES
from clients.node.cli import positive_seconds
from clients.node.output import PrefixedOutput
from clients.protocol import Encoding
from clients.recording.components import (
    player_component,
    record_path,
    recorder_component,
    recorder_process,
)
from clients.recording.play_cli import recording_file
from clients.recording.reading import recorded_topics
from clients.recording.record_cli import output_file
from clients.report.measure import Progress, measure
from clients.report.plots import write_plots
from clients.report.results import Run, json_ready
from clients.report.stats import SENSOR_TOPICS
from clients.report.text import render_comparison, render_run
from clients.stack.launcher import SIMULATOR_TOPICS, LaunchConfig, Supervisor, stack_components

log = logging.getLogger(__name__)

ENCODINGS = ("json", "cbor")
PROFILES = ("default", "thesis")  # simulator payload profiles (simulator.config.PROFILES)


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


async def run_stack(
    encoding: Encoding,
    args: argparse.Namespace,
    progress: Progress,
    log_stream: TextIO,
    profile: str = "default",
    sim_config: Path | None = None,
) -> Run:
    """Start the stack with ``encoding`` and the simulator's ``sim_config``, measure it,
    stop it. Raises RuntimeError."""
    config = LaunchConfig(
        port=0,
        encoding=encoding,
        sim_config=sim_config,
        nav_config=args.nav_config,
        autopilot=args.autopilot,
        guidance_config=args.guidance_config,
        startup_timeout_s=args.startup_timeout,
    )
    stop = asyncio.Event()
    measuring: list[asyncio.Task[Run]] = []
    label = encoding if profile == "default" else f"{profile}/{encoding}"

    def on_ready(url: str) -> None:
        progress.message(f"{label}: stack ready at {url}")
        name = f"{encoding} replay" if args.replay is not None else encoding
        task = asyncio.create_task(
            measure(url, name, args.duration, args.warmup, progress, profile, args.link)
        )
        task.add_done_callback(lambda _: stop.set())
        measuring.append(task)

    components = stack_components(config)
    if args.replay is not None:  # the recording's sensor topics in the simulator's place
        bridge, _simulator, navigation, *guidance = components
        player = player_component(args.replay, args.replay_topics)
        components = (bridge, player, navigation, *guidance)
    if args.record is not None:
        runs = len(args.encoding) * len(args.profile)
        components += (recorder_component(record_path(args.record, label.replace("/", "-"), runs)),)
    progress.message(f"{label}: starting " + ", ".join(c.title for c in components))
    supervisor = Supervisor(
        components, config, PrefixedOutput(log_stream, colour=False), on_ready=on_ready
    )
    status = await supervisor.run(stop)
    if not measuring:
        raise RuntimeError(f"the {label} stack did not start (exit status {status})")
    task = measuring[0]
    if not task.done():
        task.cancel()
        raise RuntimeError(f"the {label} stack stopped during the measurement")
    return task.result()


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
        prog="riverbridge report",
        description="Run the stack (or attach to a running one) "
        "and report per topic and stage where time and bytes go, next to the thesis's figures.",
    )
    parser.add_argument(
        "--duration",
        type=positive_seconds,
        default=30.0,
        metavar="S",
        help="seconds to measure per encoding (default %(default)s)",
    )
    parser.add_argument(
        "--warmup",
        type=positive_seconds,
        default=5.0,
        metavar="S",
        help="seconds to let the stack settle first (default %(default)s)",
    )
    parser.add_argument(
        "--encoding",
        type=_encodings,
        default=("cbor",),
        metavar="LIST",
        help="comma-separated encodings to run in turn: json, cbor "
        "(default cbor; ignored with --bridge)",
    )
    parser.add_argument(
        "--profile",
        type=_choices(PROFILES),
        default=("default",),
        metavar="LIST",
        help="comma-separated simulator payload profiles to run "
        "in turn: default, thesis (the thesis's LIDAR payload, docs/report.md; "
        "default: default; ignored with --bridge)",
    )
    parser.add_argument(
        "--bridge", metavar="URL", help="attach to the running stack at ws://HOST:PORT instead"
    )
    parser.add_argument("--json", type=Path, metavar="FILE", help="write everything as JSON")
    parser.add_argument("--plots", type=Path, metavar="DIR", help="write PNG box plots here")
    parser.add_argument("--sim-config", type=_existing_file, metavar="FILE")
    parser.add_argument("--nav-config", type=_existing_file, metavar="FILE")
    parser.add_argument(
        "--autopilot",
        action="store_true",
        help="also run guidance and control and report the closed loop (perception -> "
        "actuation per sensor, the control period) and the mission (docs/guidance.md)",
    )
    parser.add_argument("--guidance-config", type=_existing_file, metavar="FILE")
    parser.add_argument("--startup-timeout", type=positive_seconds, default=120.0, metavar="S")
    parser.add_argument(
        "--log",
        type=Path,
        metavar="FILE",
        help="where the stack's logs go (default: a file in the temp folder)",
    )
    parser.add_argument(
        "--record",
        type=output_file,
        metavar="FILE.mcap",
        help="also record every topic into this MCAP file (one file per "
        "encoding, FILE.<encoding>.mcap, when several run)",
    )
    parser.add_argument(
        "--link",
        choices=sorted(LINK_PROFILES),
        metavar="PROFILE",
        help="also read the IMU and LIDAR ashore through an emulated link (lan, wifi, 4g; "
        "docs/linkemu.md), one client per mode: plain, fresh (queue_length 1, "
        "fragment_size 65536), reduced (and reduce auto); docs/bridge.md 'Over a thin link'",
    )
    parser.add_argument(
        "--replay",
        type=recording_file,
        metavar="FILE.mcap",
        help="measure on a recording: bridge, navigation and a player of the "
        "recording's sensor topics (looped), no simulator",
    )
    return parser


def check_paths(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse unwritable outputs before spending minutes measuring (exit 2)."""
    if args.bridge is not None and not args.bridge.startswith(("ws://", "wss://")):
        parser.error(f"argument --bridge: not a ws:// URL: {args.bridge}")
    for option, path in (("--json", args.json), ("--log", args.log)):
        if path is not None and (path.is_dir() or not path.parent.is_dir()):
            parser.error(f"argument {option}: cannot write {path}")
    if (
        args.sim_config is not None
        and "default" not in args.profile
        and _sets_profile(args.sim_config)
    ):
        parser.error(f"argument --profile: {args.sim_config} sets profile itself; drop one")
    if args.replay is not None:
        if args.bridge is not None:
            parser.error("argument --replay: starts its own stack; leave out --bridge")
        if tuple(args.profile) != ("default",):
            parser.error("argument --replay: the recording sets the payload; leave out --profile")
        args.replay_topics = [t for t in SIMULATOR_TOPICS if t in recorded_topics(args.replay)]
        if not args.replay_topics:
            parser.error(
                f"argument --replay: {args.replay} has none of the simulator's "
                f"topics ({', '.join(SIMULATOR_TOPICS)})"
            )
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


async def _run_all(args: argparse.Namespace, progress: Progress, log_stream: TextIO) -> list[Run]:
    if args.bridge is not None:
        if args.record is None:
            return [
                await measure(
                    args.bridge, "attached", args.duration, args.warmup, progress, link=args.link
                )
            ]
        async with recorder_process(args.bridge, args.record):
            return [
                await measure(
                    args.bridge, "attached", args.duration, args.warmup, progress, link=args.link
                )
            ]
    runs = []
    with tempfile.TemporaryDirectory(prefix="riverbridge-report-") as folder:
        for profile in args.profile:
            sim_config = profile_sim_config(profile, args.sim_config, Path(folder))
            runs += [
                await run_stack(encoding, args, progress, log_stream, profile, sim_config)
                for encoding in args.encoding
            ]
    return runs


def main(
    argv: list[str] | None = None, *, stdout: TextIO | None = None, stderr: TextIO | None = None
) -> int:
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


def _emit(runs: Sequence[Run], args: argparse.Namespace, out: TextIO, progress: Progress) -> int:
    write: Callable[[str], Any] = out.write
    if args.replay is not None:
        write(
            f"REPLAY of {args.replay}: {', '.join(args.replay_topics)} played from the "
            "recording (looped, header stamps shifted to capture time on today's clock); "
            "no simulator ran, so there is no generate stage.\n\n"
        )
    for run in runs:
        write(render_run(run) + "\n\n")
    if len(runs) > 1:
        write(render_comparison(runs) + "\n")
    if args.json is not None:
        document = json_document(runs, args.replay)
        args.json.write_text(json.dumps(document, indent=1), encoding="utf-8")
        progress.message(f"wrote {args.json}")
    if args.plots is not None:
        for path in write_plots(runs, args.plots):
            log.debug("wrote %s", path)
        progress.message(f"wrote plots to {args.plots}")
    return 0 if any(run.spans for run in runs) else 1


def json_document(runs: Sequence[Run], replay: Path | None = None) -> dict[str, Any]:
    """The ``--json`` document: every run, and the thesis rows of all runs in one list, each
    tagged with its run (docs/report.md)."""
    return {
        "runs": json_ready(runs),
        "sensor_topics": list(SENSOR_TOPICS),
        "thesis_comparison": [
            {"run": run.label, **json_ready(row)} for run in runs for row in run.thesis_comparison
        ],
        "replay": str(replay) if replay is not None else None,
    }


if __name__ == "__main__":
    sys.exit(main())
