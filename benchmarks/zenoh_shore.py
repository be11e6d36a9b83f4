"""Vessel -> shore over an emulated Wi-Fi or 4G link: IMU and scan ages and bytes over Zenoh,
beside a websocket client over the same kind of link.

Aboard: one bridge (`--zenoh`, listening on the loopback) and one websocket publisher beside
it, sending a PointCloud2 scan at 2 Hz and a sensor_msgs/Imu at 50 Hz as CBOR, each stamped
just before encoding. Ashore, behind `clients.linkemu` (the link emulator; profiles `wifi`,
`4g`, docs/linkemu.md), one of two readers at a time, each alone on its own emulated link of
the same profile:
  zenoh      a plain eclipse-zenoh peer connected through the link to the bridge's endpoint
             (multicast, gossip and shared memory off, no listening: nothing bypasses the link),
             subscribing to the two rmw_zenoh keys and decoding the CDR with rosbags
  websocket  a websocket client through the link, subscribing with CBOR (`queue_length` 1,
             so the bridge keeps the newest only, as a shore client on a thin link should)
A message's age is the reader's wall clock after decoding minus the `header.stamp` the
publisher wrote (one clock: every process runs on this machine). Bytes are what the link
carried towards the shore. Cases alternate zenoh, websocket, zenoh, websocket ... (`--rounds`)
and the medians of each kind are reported with the machine's load.

Usage: python -m benchmarks.zenoh_shore [--profiles wifi,4g] [--seconds 15] [--rounds 2]
       [--scan-points 43200]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import random
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from benchmarks.sensor_ages import TOPICS, key_of, load, publish, read_ages, summary
from clients.linkemu import LinkEmulator, profile_named
from schemas.runtime.process import MALLOC_ENV as TUNED_MALLOC
from tests.child_process import Running, free_port, repo_env

IMU_HZ, SCAN_HZ = 50.0, 2.0
# An eighth of the thesis's 345,600-point scan (Table 4.3): 691 kB at 2 Hz is 11 Mbit/s,
# about what a Wi-Fi uplink carries and more than 4G's; the full scan saturates both.
SCAN_POINTS = 43_200
WARMUP_S = 4.0  # connection, discovery and the first scan are not what is measured
LISTENING = r"listening on ws://127\.0\.0\.1:(?P<port>\d+)"


# -- the roles (each its own process) --------------------------------------------------------


def read_zenoh(endpoint: str, domain: int, seconds: float) -> dict:
    """Ages (ms) of what arrives during `seconds` after WARMUP_S, through the link, read by a
    plain Zenoh peer (rmw_zenoh keys, rosbags CDR); the websocket reader is
    `sensor_ages.read_ages`."""
    import zenoh
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    config.insert_json5("listen/endpoints", "[]")
    # Shared memory would hand payloads across on this host and carry only references
    # through the link; a shore station is another host.
    config.insert_json5("transport/shared_memory/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    ages: dict[str, list[float]] = {"scan": [], "imu": []}
    start_ns = time.time_ns() + int(WARMUP_S * 1e9)

    def take(topic: str, type_name: str, sample: zenoh.Sample) -> None:
        now = time.time_ns()
        msg = store.deserialize_cdr(sample.payload.to_bytes(), type_name)
        sent_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if sent_ns >= start_ns:
            ages[key_of(topic)].append((now - sent_ns) / 1e6)

    with zenoh.open(config) as session:
        subscribers = []
        for topic, type_name in TOPICS:
            package, kind, name = type_name.split("/")
            key = f"{domain}/{topic.strip('/')}/{package}::{kind}::dds_::{name}_/*"
            subscribers.append(
                session.declare_subscriber(key, lambda s, t=topic, n=type_name: take(t, n, s))
            )
        print("subscribed", flush=True)
        time.sleep(WARMUP_S + seconds)
        for subscriber in subscribers:
            subscriber.undeclare()
    return ages


# -- the driver -------------------------------------------------------------------------------


@contextlib.contextmanager
def vessel_bridge(domain: int, zenoh_port: int, sndbuf_bytes: int) -> Iterator[int]:
    argv = [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "warning"]
    argv += ["--zenoh", "--domain", str(domain), "--zenoh-listen", f"tcp/127.0.0.1:{zenoh_port}"]
    config = Path(tempfile.mkdtemp()) / "vessel_zenoh.json5"
    if sndbuf_bytes:  # the user's way to bound what waits in the kernel: --zenoh-config
        config.write_text(
            json.dumps(
                {
                    "mode": "peer",
                    "scouting": {"multicast": {"enabled": False}},
                    "transport": {"link": {"tcp": {"so_sndbuf": sndbuf_bytes}}},
                }
            )
        )
        argv += ["--zenoh-config", str(config)]
    child = Running(argv, env=repo_env(TUNED_MALLOC))
    try:
        yield int(child.wait_for_line(LISTENING).group("port"))
    finally:
        child.stop()
        child.kill_session()


async def run_role(argv: list[str], ready: asyncio.Event | None = None) -> dict:
    """Run one role in its own process; its last JSON line."""
    process = await asyncio.create_subprocess_exec(
        *argv, env=repo_env(), stdout=asyncio.subprocess.PIPE
    )
    assert process.stdout is not None
    last = "{}"
    async for raw in process.stdout:
        line = raw.decode().strip()
        if line == "subscribed" and ready is not None:
            ready.set()
        elif line.startswith("{"):
            last = line
    await process.wait()
    return dict(json.loads(last))


def role(*args: str) -> list[str]:
    return [sys.executable, "-m", "benchmarks.zenoh_shore", *args]


async def one_case(
    reader: str, profile: str, ws_port: int, zenoh_port: int, domain: int, args: argparse.Namespace
) -> tuple[dict, int]:
    """One reader alone on its own emulated link while the vessel publishes."""
    upstream = zenoh_port if reader == "zenoh" else ws_port
    async with LinkEmulator(profile, upstream=("127.0.0.1", upstream), seed=1) as link:
        ready = asyncio.Event()
        if reader == "zenoh":
            argv = role("--role", "zenoh", "--endpoint", f"tcp/127.0.0.1:{link.port}")
            argv += ["--domain", str(domain)]
        else:
            argv = role("--role", "websocket", "--url", f"ws://127.0.0.1:{link.port}")
        reading = asyncio.create_task(run_role([*argv, "--seconds", str(args.seconds)], ready))
        async with asyncio.timeout(60):
            await ready.wait()
        pub = role("--role", "publish", "--url", f"ws://127.0.0.1:{ws_port}")
        pub += ["--seconds", str(WARMUP_S + args.seconds), "--scan-points", str(args.scan_points)]
        await run_role(pub)
        ages = await reading
        return ages, link.stats.carried_bytes["to_client"]


async def drive(args: argparse.Namespace) -> None:
    domain, zenoh_port = random.randint(100, 230), free_port()
    scan_bytes = args.scan_points * 16
    print(
        f"{args.scan_points:,}-point scan ({scan_bytes:,} B) at {SCAN_HZ:g} Hz + Imu at "
        f"{IMU_HZ:g} Hz from the vessel; {args.seconds:g} s per case after {WARMUP_S:g} s; "
        f"Zenoh send buffer {args.zenoh_sndbuf or 'autotuned'}; {load()}"
    )
    with vessel_bridge(domain, zenoh_port, args.zenoh_sndbuf) as ws_port:
        for profile in args.profiles.split(","):
            print(f"link {profile}: {profile_named(profile)}")
            medians: dict[str, list[float]] = {}
            for n in range(args.rounds):
                for reader in ("zenoh", "websocket"):
                    ages, carried = await one_case(
                        reader, profile, ws_port, zenoh_port, domain, args
                    )
                    print(
                        f"  {reader:<9} round {n + 1}: {carried / 1e6:7.1f} MB to shore; {load()}"
                    )
                    for key, hz in (("imu", IMU_HZ), ("scan", SCAN_HZ)):
                        print(
                            f"    {key:<4} {summary(ages.get(key, []), round(hz * args.seconds))}"
                        )
                        if ages.get(key):
                            medians.setdefault(f"{reader} {key}", []).append(
                                statistics.median(ages[key])
                            )
            print(
                "  medians of the rounds: "
                + ", ".join(f"{k} {statistics.median(v):.1f} ms" for k, v in medians.items())
            )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--profiles", default="wifi,4g")
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--scan-points", type=int, default=SCAN_POINTS)
    parser.add_argument(
        "--zenoh-sndbuf",
        type=int,
        default=0,
        help="the vessel bridge's Zenoh TCP send buffer in bytes, through --zenoh-config "
        "(default 0: the kernel's autotuning)",
    )
    parser.add_argument("--role", choices=("publish", "websocket", "zenoh"), help=argparse.SUPPRESS)
    parser.add_argument("--url", help=argparse.SUPPRESS)
    parser.add_argument("--endpoint", help=argparse.SUPPRESS)
    parser.add_argument("--domain", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    for profile in args.profiles.split(","):
        try:
            profile_named(profile)
        except KeyError as exc:
            parser.error(str(exc))
    if args.role == "publish":
        sent = publish(args.url, args.seconds, args.scan_points, SCAN_HZ, IMU_HZ)
        print(json.dumps(asyncio.run(sent)))
    elif args.role == "websocket":
        ages = read_ages(args.url, args.seconds, WARMUP_S, queue_length=1)
        print(json.dumps(asyncio.run(ages)))
    elif args.role == "zenoh":
        print(json.dumps(read_zenoh(args.endpoint, args.domain, args.seconds)))
    else:
        asyncio.run(drive(args))
    return 0


if __name__ == "__main__":
    sys.exit(main())
