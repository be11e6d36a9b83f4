"""Relay through the bridge: one publisher process and one subscriber process, one websocket
each (as roslibjs, ROS#, Unity and Foxglove clients connect), JSON and CBOR.

Workloads (issue 11), each printed beside the reference rosbridge_suite 0.11.17 figures measured
on this machine in the issue (stored figures, printed with their source and "NOT re-measured"):

1. burst: 15,000 ~100-byte ``std_msgs/String`` sent as fast as the publisher can while the
   subscriber reads as fast as it can: delivered, loss, delivered/s, ages;
2. sustained: the same messages for ``--seconds``, delivered/s and loss;
3. scan + IMU: a full 345,600-point ``sensor_msgs/PointCloud2`` (5.5 MB) at 2 Hz and a 50 Hz
   ``sensor_msgs/Imu`` on the same publisher connection and the same subscriber connection:
   scan age p50/p99/max and IMU age p99/max;
4. scan2 (only when asked for): the same with the scan and the IMU each on a connection of its
   own, in the publisher and in the subscriber: does a second connection still help?

Ages run from just before the publisher encodes (the stamp inside the message) to just after
the subscriber decoded, on one wall clock. The clients are plain ``websockets`` connections
that behave like a careful third-party client: big JSON frames are encoded and decoded on a worker
thread, in order, as riverbridge's own client library does, so the clients add as little as
they can.

Usage: python benchmarks/relay.py [--only burst,sustained,scan] [--encodings json,cbor]
       [--repeat N] [--compare /work/main] [--floor] [--url ws://host:port]
       [-- bridge options...]
With --repeat, --compare (another checkout's bridge) or --floor (a bare websockets relay that
forwards frames unvalidated), the relays run interleaved and the medians are printed side by
side with their ratios to this checkout's bridge.

Measured here, quiet (`--compare <checkout> --floor --repeat 3`, load 0.02-2.3 from the
benchmark itself; two sittings, medians of 3 interleaved runs each; "before" = the bridge
before issue 11, measured in an earlier sitting at load 1.2-3.4):

    workload          this bridge                before               bare relay (floor)
    burst JSON        15,000; 27,600-36,900/s    ~255 (98.3 % lost)   15,000; 46,100-53,400/s
    burst CBOR        15,000; 29,400-32,700/s    ~225 (98.5 % lost)   15,000; 40,900-46,900/s
    sustained JSON    35,300-37,800/s, lossless  320/s (99 % lost)    58,700-60,600/s
    sustained CBOR    34,700-35,200/s, lossless  350/s (99 % lost)    56,300-59,800/s
    scan+IMU JSON     scan p50 30.5-33.7 ms,     39.5 ms, 22.0 ms     29.3-31.4 ms, 7.0-7.1 ms
                      IMU p99 7.4-9.2 ms
    scan+IMU CBOR     scan p50 12.1-14.4 ms,     16.0 ms, 6.0 ms      11.9-12.5 ms, 2.2 ms
                      IMU p99 3.2-4.0 ms

The bare relay forwards the publisher's frame as it came and validates nothing: on one
connection its scan and IMU figures are what the clients, the copies and the kernel cost here.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import multiprocessing as mp
import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import numpy as np
from relay_roles import cpu_s, run_role

from schemas.runtime.process import MALLOC_ENV as TUNED_MALLOC

WARMUP_S = 1.0  # scan workload: samples stamped in the first second are not counted

# Reference rosbridge_suite 0.11.17 figures from issue 11, same machine, one sitting. They are
# stored, not re-measured by this script (rosbridge_suite is not installed here), so every line
# that prints one says where it comes from and when.
REFERENCE_SOURCE = (
    "rosbridge_suite 0.11.17 as measured in issue 11 (stored here 2026-11-24), NOT re-measured"
)
REFERENCE = {
    "burst": "10,041 of 15,000 delivered",
    "sustained": "3,300-3,600 msg/s",
    "scan-cbor": "does not accept CBOR publishes",
    "scan-json": "scan p50 1,595 ms, IMU p99 546 ms",
    "scan2-cbor": "-",
    "scan2-json": "-",
}
TARGET = {
    "burst": "all 15,000 delivered",
    "sustained": ">= 20,000 msg/s, lossless",
    "scan-cbor": "scan p50 <= 12 ms, IMU p99 <= 5 ms",
    "scan-json": "scan p50 <= 45 ms, IMU p99 <= 5 ms",
    "scan2-cbor": "two connections each: does a second one still help?",
    "scan2-json": "two connections each: does a second one still help?",
}


# -- orchestration -----------------------------------------------------------------------------


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else float("nan")


def one_run(
    url: str, workload: str, encoding: str, args: argparse.Namespace, bridge_pid: int | None
) -> dict[str, Any]:
    ctx = mp.get_context("spawn")
    binary = encoding == "cbor"
    sub_end, sub_pipe = ctx.Pipe()
    pub_end, pub_pipe = ctx.Pipe()
    sub = ctx.Process(target=run_role, args=("sub", sub_pipe, url, binary, workload))
    sub.start()
    if not sub_end.poll(30) or sub_end.recv() != "ready":
        raise RuntimeError("subscriber did not start")
    bridge_cpu = cpu_s(bridge_pid) if bridge_pid else float("nan")
    pub = ctx.Process(
        target=run_role, args=("pub", pub_pipe, url, binary, workload, args.count, args.seconds)
    )
    pub.start()
    sent, elapsed, pub_cpu = pub_end.recv()
    sub_end.send(sent)
    seen, sub_cpu = sub_end.recv()
    bridge_cpu = (cpu_s(bridge_pid) if bridge_pid else float("nan")) - bridge_cpu
    pub.join(10)
    sub.join(10)
    return {
        "sent": sent,
        "elapsed_s": elapsed,
        "seen": seen,
        "cpu_s": {"bridge": bridge_cpu, "publisher": pub_cpu, "subscriber": sub_cpu},
    }


def summarize(workload: str, encoding: str, result: dict[str, Any]) -> list[str]:
    sent, seen = result["sent"], result["seen"]
    lines = []
    for topic, n_sent in sent.items():
        got = seen[topic]
        ages = got["ages_ms"]
        if workload.startswith("scan"):
            ages = ages[int(WARMUP_S * (2 if topic == "/lidar" else 50)) :]
        span_s = max(1e-9, (got["last_ns"] - got["first_ns"]) / 1e9)
        loss = n_sent - got["count"]
        lines.append(
            f"  {topic:<9} sent {n_sent:>7,} in {result['elapsed_s']:5.2f} s  delivered "
            f"{got['count']:>7,} ({got['count'] / span_s:>8,.0f}/s)  loss {loss:>6,} "
            f"({100 * loss / max(1, n_sent):4.1f} %)  out of order {got['out_of_order']}  "
            f"age p50 {percentile(ages, 50):7.1f}  p99 {percentile(ages, 99):7.1f}  "
            f"max {max(ages, default=float('nan')):7.1f} ms"
        )
    cpu = result["cpu_s"]
    lines.append(
        "  CPU s: "
        + ", ".join(f"{name} {seconds:.2f}" for name, seconds in cpu.items())
        + " (from connected to done)"
    )
    key = workload if not workload.startswith("scan") else f"{workload}-{encoding}"
    lines.append(f"  reference ({REFERENCE_SOURCE}): {REFERENCE[key]}; target: {TARGET[key]}")
    return lines


def start_bridge(extra: list[str], root: str | None) -> tuple[subprocess.Popen[str], str]:
    env = {**os.environ, **TUNED_MALLOC}
    if root is not None:  # another checkout's bridge (e.g. main, for a before/after)
        root = os.path.abspath(root)
        env["PYTHONPATH"] = root
    process = subprocess.Popen(
        [sys.executable, "-m", "bridge", "--port", "0", "--log-level", "warning", *extra],
        stderr=subprocess.PIPE,
        env=env,
        text=True,
        cwd=root,
    )
    assert process.stderr is not None
    for line in process.stderr:
        match = re.search(r"listening on (ws://\S+)", line)
        if match:
            return process, match.group(1)
    raise RuntimeError("bridge exited before listening")


async def floor_relay(pipe: Connection) -> None:
    """The floor: a bare websockets relay that forwards publish frames as they came, without
    validation or re-encoding, and answers every call (the issue's "40-line relay")."""
    import cbor2
    import orjson
    from websockets.asyncio.server import serve
    from websockets.exceptions import ConnectionClosed

    subscribers: dict[str, set[Any]] = {}

    async def relay(ws: Any) -> None:
        async for data in ws:
            op = orjson.loads(data) if isinstance(data, str) else cbor2.loads(data)
            if op["op"] == "publish":
                for sub in list(subscribers.get(op["topic"], ())):
                    with contextlib.suppress(ConnectionClosed):
                        await sub.send(data)
            elif op["op"] == "subscribe":
                subscribers.setdefault(op["topic"], set()).add(ws)
            elif op["op"] == "call_service":
                with contextlib.suppress(ConnectionClosed):
                    await ws.send(
                        orjson.dumps(
                            {
                                "op": "service_response",
                                "id": op.get("id"),
                                "service": op["service"],
                                "values": {},
                                "result": True,
                            }
                        ).decode()
                    )
        for subs in subscribers.values():
            subs.discard(ws)

    async with serve(
        relay, "127.0.0.1", 0, compression=None, max_size=None, write_limit=1024 * 1024
    ) as server:
        pipe.send(server.sockets[0].getsockname()[1])
        await asyncio.Future()


def run_floor(pipe: Connection) -> None:
    asyncio.run(floor_relay(pipe))


@dataclass
class Target:
    """A relay under test: its label, URL and (if we started it) process id."""

    label: str
    url: str
    pid: int | None
    stop: Callable[[], None]


def start_targets(args: argparse.Namespace) -> list[Target]:
    targets = []
    if args.url:
        targets.append(Target("given", args.url, None, lambda: None))
    else:
        process, url = start_bridge(args.bridge_args, None)
        targets.append(Target("this", url, process.pid, process.terminate))
    if args.compare:
        process, url = start_bridge(args.bridge_args, args.compare)
        targets.append(
            Target(
                os.path.basename(os.path.abspath(args.compare)), url, process.pid, process.terminate
            )
        )
    if args.floor:
        ctx = mp.get_context("spawn")
        end, pipe = ctx.Pipe()
        floor = ctx.Process(target=run_floor, args=(pipe,), daemon=True)
        floor.start()
        targets.append(Target("floor", f"ws://127.0.0.1:{end.recv()}", floor.pid, floor.terminate))
    return targets


def metrics(workload: str, result: dict[str, Any]) -> dict[str, float]:
    """The figures of one run, flat: delivered/s, loss %, ages per topic; CPU per process."""
    out: dict[str, float] = {}
    for topic, n_sent in result["sent"].items():
        got = result["seen"][topic]
        ages = got["ages_ms"]
        if workload.startswith("scan"):
            ages = ages[int(WARMUP_S * (2 if topic == "/lidar" else 50)) :]
        span_s = max(1e-9, (got["last_ns"] - got["first_ns"]) / 1e9)
        out[f"{topic} delivered/s"] = got["count"] / span_s
        out[f"{topic} loss %"] = 100 * (n_sent - got["count"]) / max(1, n_sent)
        for name, q in (("p50", 50), ("p99", 99), ("max", 100)):
            out[f"{topic} age {name} ms"] = percentile(ages, q)
    for name, seconds in result["cpu_s"].items():
        out[f"CPU s {name}"] = seconds
    return out


def median_table(targets: list[Target], runs: dict[str, list[dict[str, float]]]) -> list[str]:
    """Medians per target, and each target's ratio to the first."""
    labels = [t.label for t in targets]
    head = (
        f"  {'median of ' + str(len(runs[labels[0]])) + ' runs':<28}"
        + "".join(f"{label:>12}" for label in labels)
        + "".join(f"{label + '/' + labels[0]:>14}" for label in labels[1:])
    )
    lines = [head]
    for key in runs[labels[0]][0]:
        medians = [float(np.median([run[key] for run in runs[label]])) for label in labels]
        ratios = [m / medians[0] if medians[0] else float("nan") for m in medians[1:]]
        lines.append(
            f"  {key:<28}"
            + "".join(f"{m:>12,.1f}" for m in medians)
            + "".join(f"{r:>14.2f}" for r in ratios)
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        default="burst,sustained,scan",
        help="comma-separated workloads (default %(default)s)",
    )
    parser.add_argument("--encodings", default="json,cbor", help="default %(default)s")
    parser.add_argument("--count", type=int, default=15_000, help="burst size")
    parser.add_argument(
        "--seconds", type=float, default=8.0, help="duration of the sustained and scan workloads"
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs per workload and relay; with more than one, print medians",
    )
    parser.add_argument(
        "--interleave",
        action="store_true",
        help="with --repeat: run every workload once per round (for comparing "
        "workloads, e.g. scan against scan2, under the same load)",
    )
    parser.add_argument("--url", help="use a running bridge instead of starting one")
    parser.add_argument(
        "--compare",
        metavar="DIR",
        help="also run the bridge of another checkout (e.g. /work/main), "
        "interleaved, and print ratios",
    )
    parser.add_argument(
        "--floor",
        action="store_true",
        help="also run a bare websockets relay (no validation), the floor",
    )
    parser.add_argument("bridge_args", nargs="*", help="options for `python -m bridge`")
    args = parser.parse_args(argv)
    os.environ.update(TUNED_MALLOC)  # the client processes move megabytes too
    targets = start_targets(args)
    try:
        print(
            f"relays: {', '.join(f'{t.label} {t.url}' for t in targets)} "
            f"{' '.join(args.bridge_args)}; load average {os.getloadavg()[0]:.2f} (1 min)"
        )
        cases = [(w, e) for w in args.only.split(",") for e in args.encodings.split(",")]
        if args.interleave:  # every case once per round, so a change of load hits them all
            runs = {case: new_runs(targets) for case in cases}
            for _ in range(args.repeat):
                for case in cases:
                    run_case(targets, *case, args, runs[case])
            for case in cases:
                print_case(targets, *case, runs[case])
        else:
            for case in cases:
                runs = new_runs(targets)
                for _ in range(args.repeat):
                    run_case(targets, *case, args, runs)
                print_case(targets, *case, runs)
    finally:
        for target in targets:
            target.stop()
    return 0


Runs = dict[str, Any]  # per target label: list of metrics dicts, and "loads"


def new_runs(targets: list[Target]) -> Runs:
    return {"loads": [], **{t.label: [] for t in targets}}


def run_case(
    targets: list[Target], workload: str, encoding: str, args: argparse.Namespace, runs: Runs
) -> None:
    """One run of the case on every target (in turn), appended to `runs`."""
    for target in targets:
        result = one_run(target.url, workload, encoding, args, target.pid)
        runs["loads"].append(os.getloadavg()[0])
        runs[target.label].append(metrics(workload, result))
        runs.setdefault("last", result)


def print_case(targets: list[Target], workload: str, encoding: str, runs: Runs) -> None:
    loads = runs["loads"]
    if len(loads) == 1:
        print(f"{workload} {encoding}  (load {loads[0]:.2f})")
        print("\n".join(summarize(workload, encoding, runs["last"])), flush=True)
        return
    key = workload if not workload.startswith("scan") else f"{workload}-{encoding}"
    print(
        f"{workload} {encoding}  (load {min(loads):.2f}-{max(loads):.2f}); reference "
        f"({REFERENCE_SOURCE}): {REFERENCE[key]}; target: {TARGET[key]}"
    )
    print("\n".join(median_table(targets, {t.label: runs[t.label] for t in targets})), flush=True)


if __name__ == "__main__":
    sys.exit(main())
