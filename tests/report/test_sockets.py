"""Socket byte counters: parsing `ss -tinpH` and the window's traffic of the stack; and the
kernel's counters against bytes we send ourselves over a real loopback connection."""

from __future__ import annotations

import asyncio
import os

from clients.report.measure import read_sockets
from clients.report.sockets import SocketBytes, SocketTraffic, parse_ss, window_traffic

SS_TEXT = """\
0      0      127.0.0.1:9090 127.0.0.1:50000 users:(("python3",pid=10,fd=16))
\t bbr rto:208 mss:32768 bytes_sent:5000 bytes_acked:5001 bytes_received:700 segs_out:33
0      0      127.0.0.1:50000 127.0.0.1:9090 users:(("python3",pid=20,fd=15))
\t bbr wscale:10,10 rto:208 bytes_sent:700 bytes_acked:701 bytes_received:5000 segs_out:36
0      0      127.0.0.1:9090 127.0.0.1:50002 users:(("python3",pid=10,fd=18))
\t bbr wscale:10,10 rto:208 bytes_sent:900 bytes_received:40 segs_out:25
0      0      127.0.0.1:50002 127.0.0.1:9090 users:(("python3",pid=99,fd=3))
\t bbr wscale:10,10 rto:208 bytes_sent:40 bytes_received:900
0      0      [::1]:22 [::1]:41000 users:(("sshd",pid=5,fd=3))
\t cubic rto:204
"""


def test_ss_output_parses_into_sockets():
    sockets = parse_ss(SS_TEXT)
    assert len(sockets) == 5
    assert sockets[0] == SocketBytes((10,), "127.0.0.1:9090", "127.0.0.1:50000", 5000, 700)
    assert sockets[4] == SocketBytes((5,), "[::1]:22", "[::1]:41000", 0, 0)


def test_the_window_counts_what_the_stack_sent_and_sets_the_report_apart():
    before = parse_ss(SS_TEXT)
    after = [
        SocketBytes(s.pids, s.local, s.peer, s.bytes_sent * 3, s.bytes_received) for s in before
    ]
    after.append(SocketBytes((20,), "127.0.0.1:50004", "127.0.0.1:9090", 123, 0))  # new
    traffic = window_traffic(before, after, {10: "bridge", 20: "simulator"}, [99])
    # bridge -> simulator 10,000; simulator -> bridge 1,400 + 123 on a new socket;
    # bridge -> report (pid 99) 1,800 apart; the report's own 80 and sshd not at all
    assert traffic == SocketTraffic(
        stack_bytes=10_000 + 1_400 + 123,
        instrument_bytes=1_800,
        by_process={"bridge": 10_000, "simulator": 1_523},
        sockets=4,
    )
    assert window_traffic(before, after, {77: "bridge"}, [99]) is None


async def test_the_kernel_counts_what_we_send_over_loopback():
    """A real TCP connection on 127.0.0.1: our process's sockets show the 1 MB we sent."""
    received, done = asyncio.Event(), asyncio.Event()

    async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        await reader.readexactly(1_000_000)
        received.set()
        await done.wait()  # stay established until the counters are read
        writer.close()

    server = await asyncio.start_server(serve, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    _, writer = await asyncio.open_connection("127.0.0.1", port)
    before = await read_sockets()
    writer.write(b"x" * 1_000_000)
    await writer.drain()
    await asyncio.wait_for(received.wait(), 10.0)
    after = await read_sockets()
    done.set()
    writer.close()
    server.close()
    assert before is not None and after is not None, "ss (iproute2) is missing"
    traffic = window_traffic(before, after, {os.getpid(): "me"}, [])
    assert traffic is not None
    assert 1_000_000 <= traffic.stack_bytes < 1_010_000
