"""``riverbridge play``: publish an MCAP recording into a bridge at its recorded timing.

    riverbridge play run.mcap --bridge ws://127.0.0.1:9090
    riverbridge play run.mcap --bridge URL --rate 2 --loop --topics '/lidar/*' /imu/data

Header stamps are shifted to today's clock by default (``--stamps``; docs/recording.md).

Exit codes: 0 played; 1 the bridge could not be reached or nothing was playable; 2 bad options
or not an MCAP file.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import struct
import sys
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import SeekingReader

from clients.errors import ConnectionFailed
from clients.node.cli import (
    add_client_arguments,
    non_negative_seconds,
    positive_number,
    run_until_stopped,
)
from clients.recording.player import STAMP_MODES, Player, PlayStats
from clients.recording.record_cli import add_topics_argument, ws_url
from clients.recording.topics import BRIDGE_OWNED, TopicFilter

log = logging.getLogger("clients.recording")


def recording_file(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"no such file: {text}")
    try:
        with open(path, "rb") as stream:
            SeekingReader(stream)  # reads the magic bytes
    except (McapError, OSError, struct.error) as exc:  # struct.error: under 8 bytes
        raise argparse.ArgumentTypeError(f"not an MCAP file: {text} ({exc})") from None
    return path


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverbridge play",
        description="Advertise the topics of an MCAP recording on a "
        "bridge and publish its messages at their recorded timing.",
    )
    parser.add_argument("recording", type=recording_file, metavar="FILE.mcap")
    parser.add_argument(
        "--bridge",
        type=ws_url,
        default="ws://127.0.0.1:9090",
        metavar="URL",
        help="the bridge to publish to (default %(default)s)",
    )
    parser.add_argument(
        "--rate",
        type=positive_number,
        default=1.0,
        metavar="X",
        help="playback speed, 2 = twice as fast (default %(default)s)",
    )
    parser.add_argument(
        "--loop",
        action="store_true",
        help="start again after the last message, until Ctrl-C/SIGTERM",
    )
    add_topics_argument(
        parser,
        "play only topics matching these shell patterns (default: all but "
        f"the bridge's own: {', '.join(BRIDGE_OWNED)})",
    )
    parser.add_argument(
        "--stay",
        action="store_true",
        help="after the last message, stay (paused at the end) so that a Foxglove client "
        "can seek back, until Ctrl-C/SIGTERM",
    )
    parser.add_argument(
        "--stamps",
        choices=STAMP_MODES,
        default="shift",
        help="header stamps: shift to today's clock keeping their distance to "
        "the recorded timing (default), now = time of publication, keep as "
        "recorded",
    )
    parser.add_argument(
        "--duration",
        type=non_negative_seconds,
        default=0.0,
        metavar="S",
        help="stop after S seconds (default 0: at the end, or never with --loop)",
    )
    add_client_arguments(parser)
    return parser


def summary(path: Path, stats: PlayStats) -> str:
    lines = [
        f"played {path}: {stats.total} messages on {len(stats.messages)} topics in "
        f"{stats.passes} pass(es); publishing ran at most {stats.max_late_s * 1e3:.1f} ms "
        "late"
    ]
    lines += [f"  {topic:<32} {count:>7} msgs" for topic, count in sorted(stats.messages.items())]
    lines += [f"  not played: {topic}: {why}" for topic, why in stats.skipped_topics.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=args.log_level, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    topics = TopicFilter(tuple(args.topics)) if args.topics else TopicFilter(excluded=BRIDGE_OWNED)
    player = Player(
        args.bridge,
        args.recording,
        topics=topics,
        rate=args.rate,
        loop=args.loop,
        stamps=args.stamps,
        connect_timeout_s=args.connect_timeout,
        stay=args.stay,
    )

    async def serve(stop: asyncio.Event) -> None:
        await player.run(stop)

    try:
        asyncio.run(run_until_stopped(serve, args.duration))
    except ConnectionFailed as exc:
        log.error("cannot reach the bridge at %s: %s", args.bridge, exc)
        return 1
    except McapError as exc:
        log.error("cannot read %s: %s", args.recording, exc)
        return 2
    print(summary(args.recording, player.stats), flush=True)
    return 0 if player.stats.total else 1


if __name__ == "__main__":
    sys.exit(main())
