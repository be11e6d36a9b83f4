"""`riverbridge link`: run the link emulator in front of a bridge until interrupted.

``riverbridge link --profile 4g --upstream 127.0.0.1:9090 --port 9091`` then connect clients
to ``ws://127.0.0.1:9091``. Bad arguments exit 2 naming the option.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
import sys
from collections.abc import Sequence

from clients.linkemu.profiles import PROFILES
from clients.linkemu.proxy import LinkEmulator


def _host_port(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host, int(port)


def _port(text: str) -> int:
    if not text.isdigit() or not 0 <= int(text) < 65536:
        raise argparse.ArgumentTypeError(f"expected a port 0-65535, got {text!r}")
    return int(text)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="riverbridge link",
        description="Carry TCP connections over an emulated link (rate, delay, jitter, "
        "stalls, a bounded bottleneck queue). Profiles and their sources: docs/linkemu.md.",
    )
    p.add_argument("--profile", choices=sorted(PROFILES), default="4g", help="link profile")
    p.add_argument("--upstream", type=_host_port, required=True, help="HOST:PORT to forward to")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on")
    p.add_argument("--port", type=_port, default=0, help="port to listen on (0: any free one)")
    p.add_argument("--seed", type=int, default=0, help="seed of jitter and stalls")
    return p


async def _serve(args: argparse.Namespace) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    try:
        link = LinkEmulator(
            args.profile, args.upstream, host=args.host, port=args.port, seed=args.seed
        )
        await link.start()
    except OSError as exc:
        print(f"riverbridge link: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 1
    upstream = f"{args.upstream[0]}:{args.upstream[1]}"
    print(f"link {args.profile} listening on {args.host}:{link.port} -> {upstream}", flush=True)
    try:
        await stop.wait()
    finally:
        await link.stop()
    stats = link.stats
    print(
        f"carried {stats.carried_bytes['to_client']} bytes to clients, "
        f"{stats.carried_bytes['to_server']} to the server, {stats.connections} connections",
        flush=True,
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)  # exits 2 naming the bad option
    with contextlib.suppress(KeyboardInterrupt):
        return asyncio.run(_serve(args))
    return 0
