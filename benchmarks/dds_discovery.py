"""How long a `--dds` bridge takes to see N remote endpoints appear and go, and its CPU.

A plain Cyclone DDS participant in this process (ROS 2 names, `std_msgs/String`, no
riverbridge code on the wire) creates N endpoints at once, half writers on `rt/bench/w<i>`
and half readers on `rt/bench/r<i>`; the clock runs from just before the first is created
until the bridge's rosapi `topics` lists all N (settle), then from deleting them until it
lists none (gone). The bridge's CPU (user + system, /proc) is taken over each phase. A fresh
bridge per trial, so every trial starts from the same empty view. With `--compare DIR` the
same trials run against another checkout's bridge, interleaved, in the same sitting.

Usage: python -m benchmarks.dds_discovery [--sizes 50,100,200] [--repeat 3]
       [--params on,off] [--compare /path/to/other/checkout]
"""

# No `from __future__ import annotations`: cyclonedds reads the field annotations as objects.
import argparse
import asyncio
import os
import random
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cyclonedds.core import Entity
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from benchmarks.sensor_ages import load
from bridge.dds.cyclone_xml import CycloneSettings, cyclone_xml
from clients import RosbridgeClient
from tests.child_process import REPO_ROOT, Running, repo_env

LISTENING = r"listening on ws://127\.0\.0\.1:(?P<port>\d+)"
POLL_S = 0.02
TIMEOUT_S = 60.0


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of process `pid` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Remote:
    """The remote side: one participant whose endpoints come and go."""

    def __init__(self, domain_id: int) -> None:
        settings = CycloneSettings("lo", (), "false")
        self.domain = Domain(domain_id, cyclone_xml(settings, False))
        self.participant = DomainParticipant(domain_id)
        self.ready = DataWriter(self.participant, Topic(self.participant, "rt/bench/ready", String))
        self.entities: list[Entity] = []

    def appear(self, n: int) -> None:
        for i in range(n):
            topic = Topic(self.participant, f"rt/bench/{'wr'[i % 2]}{i}", String)
            make = DataWriter if i % 2 == 0 else DataReader
            self.entities.append(make(self.participant, topic))

    def go(self) -> None:
        for entity in self.entities:
            entity.__del__()
        self.entities.clear()


async def listed(client: RosbridgeClient) -> int:
    topics = (await client.call_service("/rosapi/topics", {}))["topics"]
    return sum(1 for name in topics if name.startswith("/bench/") and name != "/bench/ready")


async def until(client: RosbridgeClient, done: Callable[[int], bool]) -> None:
    async with asyncio.timeout(TIMEOUT_S):
        while not done(await listed(client)):
            await asyncio.sleep(POLL_S)


async def trial(root: Path, remote: Remote, domain: int, n: int, params: str) -> dict[str, float]:
    argv = [sys.executable, "-m", "bridge", "--dds", "--domain", str(domain), "--port", "0"]
    env = repo_env({"RIVERBRIDGE_DDS_PARAMETERS": "1" if params == "on" else "0"})
    env["PYTHONPATH"] = str(root)
    bridge = Running([*argv, "--log-level", "warning"], env=env, cwd=root)
    try:
        url = f"ws://127.0.0.1:{bridge.wait_for_line(LISTENING).group('port')}"
        pid = bridge.process.pid
        async with RosbridgeClient(url) as client:
            async with asyncio.timeout(TIMEOUT_S):
                while (
                    "/bench/ready"
                    not in (await client.call_service("/rosapi/topics", {}))["topics"]
                ):
                    await asyncio.sleep(POLL_S)
            await asyncio.sleep(0.5)  # the bridge's own start-up discovery has settled
            cpu0, t0 = cpu_s(pid), time.perf_counter()
            remote.appear(n)
            await until(client, lambda count: count == n)
            cpu1, t1 = cpu_s(pid), time.perf_counter()
            remote.go()
            await until(client, lambda count: count == 0)
            cpu2, t2 = cpu_s(pid), time.perf_counter()
    finally:
        remote.go()
        bridge.stop()
        bridge.kill_session()
    return {
        "settle_s": t1 - t0,
        "settle_cpu_s": cpu1 - cpu0,
        "gone_s": t2 - t1,
        "gone_cpu_s": cpu2 - cpu1,
    }


def run(sizes: list[int], repeat: int, params: list[str], sides: dict[str, Path]) -> None:
    domain = random.randint(100, 230)
    remote = Remote(domain)
    print(f"domain {domain}, poll every {POLL_S * 1000:g} ms; {load()}")
    results: dict[tuple[str, str, int], list[dict[str, float]]] = {}
    for n in sizes:
        for _ in range(repeat):
            for param in params:
                for side, root in sides.items():  # interleaved: one of each in turn
                    got = asyncio.run(trial(root, remote, domain, n, param))
                    results.setdefault((side, param, n), []).append(got)
    print(f"medians of {repeat}; {load()}")
    heading = ("bridge", "params", "N", "settle ms", "CPU ms", "gone ms", "CPU ms")
    print("{:<10} {:<6} {:>4} {:>10} {:>8} {:>8} {:>8}".format(*heading))
    for (side, param, n), runs in results.items():
        med = {key: statistics.median(run[key] for run in runs) * 1000 for key in runs[0]}
        print(
            f"{side:<10} {param:<6} {n:>4} {med['settle_s']:>10.0f} {med['settle_cpu_s']:>8.0f} "
            f"{med['gone_s']:>8.0f} {med['gone_cpu_s']:>8.0f}"
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="50,100,200", help="endpoint counts, comma-separated")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--params", default="on", help="the bridge's parameter node: on,off")
    parser.add_argument("--compare", type=Path, help="another checkout's bridge, interleaved")
    args = parser.parse_args(argv)
    try:
        sizes = [int(size) for size in args.sizes.split(",")]
    except ValueError:
        parser.error(f"--sizes: not a list of integers: {args.sizes!r}")
    params = args.params.split(",")
    if not sizes or min(sizes) < 2 or not set(params) <= {"on", "off"} or args.repeat < 1:
        parser.error("--sizes takes counts of at least 2, --params on and/or off, --repeat >= 1")
    sides = {"this": REPO_ROOT}
    if args.compare is not None:
        if not (args.compare / "bridge" / "__main__.py").is_file():
            parser.error(f"--compare: no bridge checkout at {args.compare}")
        sides[args.compare.name] = args.compare.resolve()
    run(sizes, args.repeat, params, sides)
    return 0


if __name__ == "__main__":
    sys.exit(main())
