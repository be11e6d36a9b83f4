"""`riverbridge teleop` / `python -m simulator.teleop_cli`: steer the simulated vessel.

Reads single key presses from the terminal (cbreak mode: no echo, no line buffering; Ctrl-C
still raises SIGINT) through the event loop's reader, and publishes the command as a
`geometry_msgs/msg/Wrench` on `/cmd_wrench`: on every key and at a steady rate in between, so
a simulator that starts or reconnects later still receives it. One status line shows the
current command. On the way out (q, Ctrl-C, SIGTERM, end of input) a zero wrench is sent, so
the vessel is not left under power, and the terminal's settings are restored.

`--stdin-keys` accepts keys from a pipe instead of a terminal (scripts and tests).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import os
import signal
import sys
import termios
import tty
from collections.abc import Iterator
from typing import TextIO

from clients import ConnectionFailed, RosbridgeClient
from clients.node.cli import add_client_arguments
from schemas.catalogue import TOPICS
from simulator.config import SimConfig, load_config
from simulator.teleop import Action, KeyDecoder, TeleopCommand, TeleopScale

log = logging.getLogger("simulator.teleop")

COMMAND = TOPICS["cmd_wrench"].pair  # (topic, type) this client publishes
HELP_LINE = "up/w down/s: surge   left/a right/d: yaw   space: zero   q: quit"
READ_CHUNK_BYTES = 1024


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="riverbridge teleop",
        description="Steer the simulated vessel from the keyboard (publishes "
        f"{COMMAND[1]} on {COMMAND[0]}). {HELP_LINE}.",
    )
    parser.add_argument("--bridge", default="ws://127.0.0.1:9090", help="rosbridge URL")
    parser.add_argument("--config", help="the simulator's TOML file, for the vessel's limits")
    parser.add_argument(
        "--rate",
        type=float,
        default=10.0,
        help="publish rate in Hz between key presses (default %(default)s)",
    )
    parser.add_argument(
        "--steps",
        type=int,
        default=10,
        help="key presses from zero to full force (default %(default)s)",
    )
    parser.add_argument("--encoding", choices=("cbor", "json"), default="cbor")
    parser.add_argument(
        "--stdin-keys",
        action="store_true",
        help="read keys from stdin even when it is not a terminal (a pipe)",
    )
    add_client_arguments(parser, log_level="WARNING")  # the terminal is the teleop's display
    return parser


@contextlib.contextmanager
def cbreak_terminal(fd: int) -> Iterator[None]:
    """Single unechoed key presses on terminal `fd`; its settings are restored on exit."""
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd, termios.TCSANOW)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


class StatusLine:
    """The current command on one line: redrawn in place on a terminal, appended otherwise."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self._in_place = stream.isatty()

    def show(self, text: str) -> None:
        if self._in_place:
            self._stream.write(f"\r{text}\x1b[K")
        else:
            self._stream.write(f"{text}\n")
        self._stream.flush()

    def close(self) -> None:
        if self._in_place:
            self._stream.write("\n")
            self._stream.flush()


def watch_keys(fd: int, actions: asyncio.Queue[Action]) -> None:
    """Feed key presses read from `fd` to `actions` from the event loop's reader; end of
    input counts as QUIT. The caller removes the reader with `loop.remove_reader(fd)`."""
    loop = asyncio.get_running_loop()
    decoder = KeyDecoder()

    def on_readable() -> None:
        try:
            data = os.read(fd, READ_CHUNK_BYTES)
        except BlockingIOError:
            return
        if not data:
            loop.remove_reader(fd)
            actions.put_nowait(Action.QUIT)
            return
        for action in decoder.feed(data):
            actions.put_nowait(action)

    loop.add_reader(fd, on_readable)


async def steer(
    client: RosbridgeClient,
    actions: asyncio.Queue[Action],
    scale: TeleopScale,
    rate_hz: float,
    status: StatusLine,
) -> TeleopCommand:
    """Apply actions and publish the command on every key and every 1/`rate_hz` s until
    QUIT; then publish a zero wrench. Returns the command in force when QUIT came."""
    loop = asyncio.get_running_loop()
    period_s = 1.0 / rate_hz
    command = TeleopCommand()
    status.show(command.status(scale))
    await client.publish(COMMAND[0], command.wrench(scale))
    next_s = loop.time() + period_s
    try:
        while True:
            try:
                async with asyncio.timeout(max(0.0, next_s - loop.time())):
                    action = await actions.get()
            except TimeoutError:
                next_s = max(next_s + period_s, loop.time())
                await client.publish(COMMAND[0], command.wrench(scale))
                continue
            if action is Action.QUIT:
                return command
            command = command.apply(action, scale)
            status.show(command.status(scale))
            await client.publish(COMMAND[0], command.wrench(scale))
    finally:
        await client.publish(COMMAND[0], TeleopCommand().wrench(scale))


async def _run(args: argparse.Namespace, scale: TeleopScale, fd: int) -> None:
    loop = asyncio.get_running_loop()
    actions: asyncio.Queue[Action] = asyncio.Queue()
    handled = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, actions.put_nowait, Action.QUIT)
        except (RuntimeError, ValueError):  # not the main thread (e.g. called from a test)
            break
        handled.append(sig)
    status = StatusLine(sys.stdout)
    try:
        async with RosbridgeClient(
            args.bridge, encoding=args.encoding, name="teleop", connect_timeout=args.connect_timeout
        ) as client:
            await client.advertise(*COMMAND)
            print(HELP_LINE, flush=True)
            watch_keys(fd, actions)
            try:
                await steer(client, actions, scale, args.rate, status)
            finally:
                loop.remove_reader(fd)
    finally:
        status.close()
        for sig in handled:
            loop.remove_signal_handler(sig)


def _stdin_fd() -> int | None:
    """The descriptor behind `sys.stdin`, or None when there is none (a closed or fake stdin)."""
    try:
        return sys.stdin.fileno()
    except (AttributeError, OSError, ValueError):
        return None


def main(argv: list[str] | None = None) -> int:
    """0 after q / Ctrl-C / end of input; 2 for bad options or stdin not being a terminal
    (without `--stdin-keys`); 1 when the bridge cannot be reached."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    if args.rate <= 0 or args.steps < 1:
        print("riverbridge teleop: --rate must be > 0 and --steps >= 1", file=sys.stderr)
        return 2
    try:
        vessel = (load_config(args.config) if args.config else SimConfig()).vessel
    except (OSError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        print(f"riverbridge teleop: cannot use config {args.config}: {exc}", file=sys.stderr)
        return 2
    scale = TeleopScale.of(vessel, args.steps)
    fd = _stdin_fd()
    is_terminal = fd is not None and os.isatty(fd)
    if fd is None or not (is_terminal or args.stdin_keys):
        print(
            "riverbridge teleop: stdin is not a terminal; run it in an interactive terminal, "
            "or pass --stdin-keys to read keys from a pipe",
            file=sys.stderr,
        )
        return 2
    try:
        with cbreak_terminal(fd) if is_terminal else contextlib.nullcontext():
            asyncio.run(_run(args, scale, fd))
    except ConnectionFailed as exc:
        print(
            f"riverbridge teleop: cannot reach the bridge at {args.bridge}: {exc}", file=sys.stderr
        )
        return 1
    except KeyboardInterrupt:  # Ctrl-C while still connecting, before our handler is set
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
