"""``riverbridge record``: write a running bridge's topics to an MCAP file.

    riverbridge record --bridge ws://127.0.0.1:9090 --output run.mcap
    riverbridge record --bridge URL --output lidar.mcap --topics '/lidar/*' /imu/data --duration 60

Stops on Ctrl-C/SIGTERM or after ``--duration``; the file is complete (with its index) after a
clean stop and readable up to its last chunk after a crash (docs/recording.md).

Exit codes: 0 recorded; 1 the bridge could not be reached; 2 bad options.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import sys
from pathlib import Path

from clients.errors import ConnectionFailed
from clients.node.cli import add_client_arguments, non_negative_seconds, run_until_stopped
from clients.recording.mcap_file import COMPRESSIONS, TopicCounts
from clients.recording.recorder import Recorder
from clients.recording.topics import TopicFilter, check_patterns

log = logging.getLogger("clients.recording")


def ws_url(text: str) -> str:
    if not text.startswith(("ws://", "wss://")):
        raise argparse.ArgumentTypeError(f"not a ws:// URL: {text!r}")
    return text


def output_file(text: str) -> Path:
    path = Path(text)
    if path.is_dir() or not path.parent.resolve().is_dir():
        raise argparse.ArgumentTypeError(f"cannot write {text}")
    return path


def topic_pattern(text: str) -> str:
    try:
        return check_patterns([text])[0]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_topics_argument(parser: argparse.ArgumentParser, help: str) -> None:
    """--topics GLOB...: which topics `record` or `play` takes."""
    parser.add_argument(
        "--topics", nargs="+", type=topic_pattern, default=[], metavar="GLOB", help=help
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverbridge record",
        description="Record a running bridge's topics (all, or "
        "those matching --topics) into an MCAP file with ROS 2 schemas and CDR messages, for "
        "Foxglove/Lichtblick, ros2 bag and `riverbridge play`.",
    )
    parser.add_argument(
        "--bridge",
        type=ws_url,
        default="ws://127.0.0.1:9090",
        metavar="URL",
        help="the bridge to record (default %(default)s)",
    )
    parser.add_argument(
        "--output",
        "-o",
        type=output_file,
        required=True,
        metavar="FILE",
        help="the MCAP file to write (replaced if it exists)",
    )
    add_topics_argument(
        parser,
        "record only topics matching these shell patterns (default: all; "
        "new topics are picked up as they appear)",
    )
    parser.add_argument(
        "--duration",
        type=non_negative_seconds,
        default=0.0,
        metavar="S",
        help="stop after S seconds (default 0: until Ctrl-C/SIGTERM)",
    )
    parser.add_argument(
        "--compression",
        choices=tuple(COMPRESSIONS),
        default="zstd",
        help="chunk compression (default %(default)s)",
    )
    add_client_arguments(parser)
    return parser


def summary(recorder: Recorder, counts: dict[str, TopicCounts]) -> str:
    lines = [
        f"wrote {recorder.output}: {recorder.stats.messages} messages, "
        f"{recorder.stats.bytes / 1e6:.1f} MB on {len(counts)} topics"
    ]
    lines += [
        f"  {topic:<32} {c.messages:>7} msgs {c.bytes / 1e6:>9.2f} MB  {c.type_name}"
        for topic, c in sorted(counts.items())
    ]
    stats = recorder.stats
    if stats.dropped_backlog or stats.dropped_queue:
        lines.append(
            f"  DROPPED: {stats.dropped_backlog} (writer backlog full), "
            f"{stats.dropped_queue} (receive queue full)"
        )
    lines += [f"  not recorded: {topic}: {why}" for topic, why in stats.skipped_topics.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    recorder = Recorder(
        args.bridge,
        args.output,
        topics=TopicFilter(tuple(args.topics)),
        compression=args.compression,
        connect_timeout_s=args.connect_timeout,
    )
    counts: dict[str, TopicCounts] = {}

    async def serve(stop: asyncio.Event) -> None:
        counts.update(await recorder.run(stop))

    try:
        asyncio.run(run_until_stopped(serve, args.duration))
    except ConnectionFailed as exc:
        log.error("cannot reach the bridge at %s: %s", args.bridge, exc)
        return 1
    print(summary(recorder, counts), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
