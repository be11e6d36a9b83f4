"""The emulator with real sockets: rate and delay as configured, backpressure to the sender,
stalls, nothing lost or reordered; and its command line."""

from __future__ import annotations

import asyncio
import hashlib
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable

import pytest

from clients.linkemu import Direction, LinkEmulator, LinkProfile
from clients.linkemu.cli import main
from tests.child_process import running
from tests.cli_checks import assert_refused

Handler = Callable[[asyncio.StreamReader, asyncio.StreamWriter], Awaitable[None]]


async def serve(handler: Handler) -> AsyncIterator[int]:
    server = await asyncio.start_server(handler, "127.0.0.1", 0)
    try:
        yield server.sockets[0].getsockname()[1]
    finally:
        server.close()


def profile(rate_mbit: float, delay_ms: float, **stalls: float) -> LinkProfile:
    direction = Direction(rate_bps=rate_mbit * 1e6, delay_ms=delay_ms, buffer_bytes=60_000)
    return LinkProfile(name="test", to_client=direction, to_server=direction, **stalls)


def payload(nbytes: int) -> bytes:
    return hashlib.sha256(b"seed").digest() * (nbytes // 32)


async def send_then_close(data: bytes, writer: asyncio.StreamWriter) -> None:
    writer.write(data)
    await writer.drain()
    writer.close()


async def fetch_through(link_profile: LinkProfile, data: bytes) -> tuple[bytes, float, float]:
    """`data` sent by a server through the link; (received, first byte s, whole s)."""

    async def handler(_: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await send_then_close(data, writer)

    async for port in serve(handler):
        async with LinkEmulator(link_profile, ("127.0.0.1", port)) as link:
            start = time.perf_counter()
            reader, writer = await asyncio.open_connection("127.0.0.1", link.port)
            first = await reader.readexactly(1)
            first_s = time.perf_counter() - start
            received = first + await reader.read()
            writer.close()
            return received, first_s, time.perf_counter() - start
    raise AssertionError("unreachable")


async def test_bytes_cross_at_the_rate_after_the_delay_intact() -> None:
    data = payload(1_000_000)
    received, first_s, whole_s = await fetch_through(profile(20, 25), data)
    assert received == data
    assert first_s >= 0.025  # the server speaks first: one way, 25 ms
    # 8 Mbit at 20 Mbit/s: 0.4 s of link time plus the round trip
    assert 0.4 <= whole_s < 0.4 + 0.025 + 0.3


async def test_a_stall_delays_and_loses_nothing() -> None:
    data = payload(500_000)  # 0.4 s at 10 Mbit/s
    stalling = profile(10, 1, stall_every_s=0.1, stall_ms=200)
    received, _, whole_s = await fetch_through(stalling, data)
    assert received == data
    assert whole_s >= 0.4 + 0.1  # 0.4 s of link time and at least one stall (seeded: several)


async def test_a_full_link_pushes_back_on_the_sender() -> None:
    """The sender's own socket backs up: what a real bottleneck does to the bridge."""
    backed_up = asyncio.get_running_loop().create_future()

    async def handler(_: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        writer.write(payload(4_000_000))  # 3.2 s at 10 Mbit/s
        await asyncio.sleep(0.3)
        backed_up.set_result(writer.transport.get_write_buffer_size())
        writer.close()

    async for port in serve(handler):
        async with LinkEmulator(profile(10, 5), ("127.0.0.1", port)) as link:
            _, writer = await asyncio.open_connection("127.0.0.1", link.port)
            unsent = await asyncio.wait_for(backed_up, 10)
            writer.close()
    # after 0.3 s at most ~0.4 MB crossed; the kernel may hold some more, not all of it
    assert unsent > 1_000_000


async def test_each_direction_has_its_own_rate() -> None:
    """A request crosses `to_server`, its echo `to_client`; both carried and counted."""

    async def echo(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        while data := await reader.read(65536):
            writer.write(data)
            await writer.drain()
        writer.close()

    async for port in serve(echo):
        async with LinkEmulator("wifi", ("127.0.0.1", port)) as link:
            reader, writer = await asyncio.open_connection("127.0.0.1", link.port)
            start = time.perf_counter()
            writer.write(b"ping")
            assert await reader.readexactly(4) == b"ping"
            rtt_s = time.perf_counter() - start
            writer.close()
            assert link.stats.carried_bytes == {"to_client": 4, "to_server": 4}
    assert rtt_s >= 0.02  # 10 ms each way


def test_the_command_line_forwards_until_interrupted() -> None:
    async def exchange() -> None:
        async def echo(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            writer.write(await reader.readexactly(5))
            await writer.drain()
            writer.close()

        async for port in serve(echo):
            argv = [sys.executable, "-m", "clients.linkemu", "--profile", "lan"]
            with running([*argv, "--upstream", f"127.0.0.1:{port}"]) as child:
                line = await asyncio.to_thread(child.wait_for_line, r"listening on .*:(\d+) ->")
                reader, writer = await asyncio.open_connection("127.0.0.1", int(line.group(1)))
                writer.write(b"hello")
                assert await reader.readexactly(5) == b"hello"
                writer.close()
            assert "carried 5 bytes to clients" in child.text()

    asyncio.run(exchange())


@pytest.mark.parametrize(
    ("argv", "option"),
    [
        (["--upstream", "nohost"], "--upstream"),
        (["--upstream", "127.0.0.1:9090", "--profile", "5g"], "--profile"),
        (["--upstream", "127.0.0.1:9090", "--port", "70000"], "--port"),
        ([], "--upstream"),
    ],
)
def test_bad_arguments_exit_2_naming_the_option(
    argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert_refused(main, argv, option, capsys)
