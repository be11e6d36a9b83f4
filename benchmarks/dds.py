"""Ages of the full LIDAR scan and the IMU through one bridge, and through A -> DDS -> B.

The load is the thesis's (Table 4.3, section 4.2): a 345,600-point PointCloud2 (16 B a
point, 5,529,600 B of data) at 2 Hz and a sensor_msgs/Imu at 50 Hz, published as CBOR by
one websocket client and received as CBOR by another. A message's age is the subscriber's
wall clock after decoding minus the `header.stamp` the publisher wrote just before encoding
(one clock: every process runs on this machine, namespaces included).

Cases:
  one-bridge  publisher and subscriber on one bridge (the figures of benchmarks/bridge.py)
  dds-lo      publisher on bridge A, subscriber on bridge B, both on the loopback, DDS between
  dds-veth    A and B in two network namespaces joined by a veth pair (two "hosts")
  dds-wlan    dds-veth with a WLAN-like link: `tc netem` where the kernel has it, else tbf for
              the rate and an iptables rule for loss (this kernel: no netem, so no delay)
The namespace cases need root and iproute2; they are skipped with the reason otherwise.

Usage: python -m benchmarks.dds [--seconds 20] [--cases one-bridge,dds-lo,dds-veth,dds-wlan]
       [--wlan-rate-mbit 150 --wlan-delay-ms 2 --wlan-jitter-ms 1 --wlan-loss 0.1]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import random
import statistics
import subprocess
import sys
from collections.abc import Iterator

from benchmarks.sensor_ages import POINT_STEP, load, publish, read_ages, summary
from schemas.runtime.process import MALLOC_ENV as TUNED_MALLOC
from tests.child_process import Running, repo_env
from tests.dds.dds_netns import Host, LinkShape, bridge_argv, shape_link, two_hosts, why_not

SCAN_POINTS = 345_600  # Table 4.3: 1440 x 240 rays at 0.25 degrees
SCAN_HZ, IMU_HZ = 2.0, 50.0
WARMUP_S = 4.0  # discovery and first-message set-up are not what is measured
LISTENING = r"listening on ws://127\.0\.0\.1:(?P<port>\d+)"
CASES = ("one-bridge", "dds-lo", "dds-veth", "dds-wlan")
# FL WLAN 1101 (thesis Table 3.1) is IEEE 802.11n, 300 Mbit/s gross: about half of that as
# throughput on a good 2x2 link, a couple of milliseconds of air time and retries.
WLAN = LinkShape(rate_mbit=150.0, delay_ms=2.0, jitter_ms=1.0, loss_percent=0.1)
EXTRA_BRIDGE_ARGS: list[str] = []  # --untuned adds --dds-untuned


# -- the driver -------------------------------------------------------------------------------


def role_argv(role: str, url: str, seconds: float, host: Host | None) -> list[str]:
    argv = [
        sys.executable,
        "-m",
        "benchmarks.dds",
        "--role",
        role,
        "--url",
        url,
        "--seconds",
        str(seconds),
    ]
    return host.command(argv) if host is not None else argv


@contextlib.contextmanager
def bridge(
    host: Host | None = None, peer: Host | None = None, domain: int | None = None
) -> Iterator[str]:
    dds_options = EXTRA_BRIDGE_ARGS if domain is not None else []
    argv = bridge_argv(host, peer, domain, "--log-level", "warning", *dds_options)
    child = Running(argv, env=repo_env(TUNED_MALLOC))
    try:
        port = child.wait_for_line(LISTENING).group("port")
        yield f"ws://127.0.0.1:{port}"
    finally:
        child.stop()
        child.kill_session()


def run_clients(
    pub_url: str, sub_url: str, seconds: float, pub_host: Host | None, sub_host: Host | None
) -> dict:
    sub = Running(role_argv("sub", sub_url, seconds, sub_host), env=repo_env())
    try:
        sub.wait_for_line("subscribed")
        pub = subprocess.run(
            role_argv("pub", pub_url, WARMUP_S + seconds, pub_host),
            env=repo_env(),
            capture_output=True,
            text=True,
            check=True,
        )
        sub.process.wait(timeout=seconds + WARMUP_S + 30)
    finally:
        sub.kill_session()
    ages = json.loads(next(line for line in reversed(sub.lines) if line.startswith("{")))
    sent = json.loads(pub.stdout.strip().splitlines()[-1])["sent"]
    return {"ages": ages, "sent": sent}


def run_case(case: str, seconds: float, shape: LinkShape) -> tuple[dict, str]:
    domain = random.randint(100, 230)
    if case == "one-bridge":
        with bridge() as url:
            return run_clients(url, url, seconds, None, None), "one bridge on 127.0.0.1"
    if case == "dds-lo":
        with bridge(domain=domain) as url_a, bridge(domain=domain) as url_b:
            return run_clients(url_a, url_b, seconds, None, None), f"domain {domain} on lo"
    with two_hosts(tag=case[-1]) as (a, b):
        link = "veth, no shaping"
        if case == "dds-wlan":
            link = f"A->B {shape_link(a, shape)}; B->A {shape_link(b, shape)}"
        with bridge(a, b, domain) as url_a, bridge(b, a, domain) as url_b:
            return run_clients(url_a, url_b, seconds, a, b), f"domain {domain}, {link}"


def drive(cases: list[str], seconds: float, shape: LinkShape) -> None:
    print(
        f"{SCAN_POINTS:,}-point scan ({SCAN_POINTS * POINT_STEP:,} B) at {SCAN_HZ:g} Hz + "
        f"Imu at {IMU_HZ:g} Hz, CBOR; {seconds:g} s per case after {WARMUP_S:g} s warm-up; "
        f"Cyclone {'untuned' if EXTRA_BRIDGE_ARGS else 'tuned'}; {load()}"
    )
    medians: dict[str, float] = {}
    for case in cases:
        reason = why_not() if case in ("dds-veth", "dds-wlan") else None
        if reason is not None:
            print(f"{case:<10} skipped: {reason}")
            continue
        result, where = run_case(case, seconds, shape)
        ages = result["ages"]
        print(f"{case:<10} ({where}); {load()}")
        for key, label, hz in (("scan", "scan", SCAN_HZ), ("imu", "imu ", IMU_HZ)):
            print(f"  {label} {summary(ages[key], round(hz * seconds))}")
        if ages["scan"]:
            medians[case] = statistics.median(ages["scan"])
    if "one-bridge" in medians:
        base = medians["one-bridge"]
        print(
            "scan median vs one bridge: "
            + ", ".join(
                f"{case} x{median / base:.2f}"
                for case, median in medians.items()
                if case != "one-bridge"
            )
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--wlan-rate-mbit", type=float, default=WLAN.rate_mbit)
    parser.add_argument("--wlan-delay-ms", type=float, default=WLAN.delay_ms)
    parser.add_argument("--wlan-jitter-ms", type=float, default=WLAN.jitter_ms)
    parser.add_argument(
        "--wlan-loss", type=float, default=WLAN.loss_percent, help="percent of packets lost"
    )
    parser.add_argument(
        "--untuned",
        action="store_true",
        help="run the DDS bridges with Cyclone's own buffers (--dds-untuned)",
    )
    parser.add_argument("--role", choices=("pub", "sub"), help=argparse.SUPPRESS)
    parser.add_argument("--url", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.role == "pub":
        print(
            json.dumps(asyncio.run(publish(args.url, args.seconds, SCAN_POINTS, SCAN_HZ, IMU_HZ)))
        )
        return 0
    if args.role == "sub":
        ages = read_ages(args.url, args.seconds, WARMUP_S, grace_s=5.0)
        print(json.dumps(asyncio.run(ages)))
        return 0
    if args.untuned:
        EXTRA_BRIDGE_ARGS.append("--dds-untuned")
    cases = [c for c in args.cases.split(",") if c]
    unknown = set(cases) - set(CASES)
    if unknown:
        parser.error(f"unknown cases: {', '.join(sorted(unknown))} (choose from {CASES})")
    drive(
        cases,
        args.seconds,
        LinkShape(args.wlan_rate_mbit, args.wlan_delay_ms, args.wlan_jitter_ms, args.wlan_loss),
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
