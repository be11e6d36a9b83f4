"""Benchmark of the simulator's numeric core against its per-sensor time budgets.

Run: `python -m benchmarks.simulator [--repeat 30] [--threads 2] [--tuned-malloc]
[--rtf-seconds 30] [--quick]`

Builds the default thesis scene (~500k triangles) and times, per call: a full LIDAR scan
(345,600 rays: ray cast + point build + PointCloud2 dict), a camera frame (640 x 480 ray cast
+ shading + JPEG + CompressedImage dict), a RADAR sweep (72 beams x 60 rays + RadarImage dict)
and one 50 Hz physics step with its IMU message. Prints wall min / median / p90 and the
median's ratio to its target (< 1 meets it).

The machine is shared with other work, so every timed call is paired with a reference call:
the embreex DISTANCE query of the LIDAR rays split over 2 threads, which
performance-measurements.md 2(d) measured at 20.2 ms median on a quiet machine of this kind.
`load` = reference median / 20.2 says how much slower the machine is right now; `quiet est.`
= median / load estimates the quiet-machine time.

Then the whole simulator runs for `--rtf-seconds` (default 30) with every sensor on at its
configured rate: the real `SimulatorNode` against a real `python -m bridge` child process,
with one listener subscribed to every topic. It reports the real-time factor (simulated
physics time / wall time; target 1.00 +- 0.01) and per sensor the configured, generated and
received rates. `--quick` runs 5 repeats and a 5 s real-time run. OpenBLAS is limited to one
thread as in the simulator process; `--multithreaded-blas` leaves its default, for comparison.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from benchmarks.malloc import malloc_tuned, rerun_tuned
from clients import RosbridgeClient
from schemas.catalogue import TOPICS as CATALOGUE
from schemas.catalogue import published_by
from schemas.runtime.process import single_threaded_blas
from simulator.camera import Camera
from simulator.config import SimConfig
from simulator.dynamics import Command, VesselDynamics, VesselState
from simulator.frames import Pose2D, rotate_rows, sensor_pose_in_map
from simulator.imu import Imu
from simulator.lidar import Lidar
from simulator.node import SimulatorNode
from simulator.radar import Radar
from simulator.scene import Scene, build_scene
from simulator.sensor import config_value
from tests.simulator.sim_processes import header_stamp_s, running_bridge

# Targets on 2 cores (issue 3). LIDAR and camera come from the brief; the RADAR and IMU budgets
# are 1 % of the 500 ms sweep period and 5 % of the 20 ms physics period.
TARGETS_MS = {"lidar scan": 30.0, "camera frame": 40.0, "radar sweep": 5.0, "imu step": 1.0}
RTF_TOLERANCE = 0.01  # issue 3: real-time factor 1.00 +- 0.01 with every sensor at its rate
RTF_WARMUP_S = 3.0  # Embree's and OpenCV's lazy set-up and the first connections
QUIET_REFERENCE_MS = 20.2  # performance-measurements.md 2(d): DISTANCE on 2 threads, median
# Every topic the simulator streams (schemas.catalogue) -> (name, type); the worker sensors
# (their own schedule and thread) have generation times and skip counts.
TOPICS = {t.key: t.pair for t in published_by("simulator", "sensor", "realtime")}
HEAVY_SENSORS = tuple(t.key for t in published_by("simulator", "sensor"))


def reference_query(scene: Scene, lidar: Lidar, pool: ThreadPoolExecutor) -> Callable[[], object]:
    """The DISTANCE query of every LIDAR ray from the start pose, in two halves on `pool`."""
    origin, rotation = sensor_pose_in_map(scene.start_pose, lidar.cfg.mount, scene.water_level_m)
    directions = np.empty_like(lidar.directions_sensor)
    rotate_rows(lidar.directions_sensor, rotation, directions)
    origins = np.ascontiguousarray(np.broadcast_to(origin.astype(np.float32), directions.shape))
    half = len(directions) // 2
    halves = [slice(0, half), slice(half, len(directions))]

    def query() -> None:
        futures = [
            pool.submit(scene.embree.run, origins[h], directions[h], query="DISTANCE")
            for h in halves
        ]
        for future in futures:
            future.result()

    return query


def paired_times_ms(
    work: Callable[[int], object], reference: Callable[[], object], repeat: int, warmup: int = 3
) -> tuple[list[float], list[float]]:
    """Wall times (ms) of `work(i)` and of `reference()` run just before it, `repeat` times."""
    for i in range(warmup):
        work(i)
    work_ms, reference_ms = [], []
    for i in range(repeat):
        start = time.perf_counter()
        reference()
        middle = time.perf_counter()
        work(i)
        work_ms.append((time.perf_counter() - middle) * 1e3)
        reference_ms.append((middle - start) * 1e3)
    return work_ms, reference_ms


def poses_along_the_river(start: Pose2D, count: int) -> list[Pose2D]:
    """Poses a few metres apart with slightly varying heading, so no scan repeats exactly."""
    return [
        Pose2D(start.x_m + 0.5 * k, start.y_m + 2.0 * k, start.yaw_rad + 0.01 * k)
        for k in range(count)
    ]


def report(name: str, times: tuple[list[float], list[float]], extra: str = "") -> None:
    wall = sorted(times[0])
    median = statistics.median(wall)
    p90 = wall[int(0.9 * (len(wall) - 1))]
    load = statistics.median(times[1]) / QUIET_REFERENCE_MS
    target = TARGETS_MS[name]
    verdict = "ok" if median <= target else "OVER"
    print(
        f"{name:<13} min {wall[0]:7.2f}  median {median:7.2f}  p90 {p90:7.2f} ms | "
        f"target {target:5.1f} ratio {median / target:5.2f} {verdict:<4} | "
        f"load {load:4.2f} quiet est. {median / load:6.2f} ms | {extra}"
    )


class SteppingNode(SimulatorNode):
    """The real simulator node, counting the physics steps it takes: simulated time is
    steps x dt (a step skipped to catch up after a stall is simulated time lost)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.steps = 0

    def _step(self):
        self.steps += 1
        return super()._step()


@dataclass(frozen=True)
class NodeSnapshot:
    """The node's counters at one wall-clock instant."""

    wall_s: float
    steps: int
    generated: dict[str, int]  # heavy sensor -> messages generated so far
    skipped: dict[str, int]  # heavy sensor -> ticks skipped so far

    @classmethod
    def of(cls, node: SteppingNode) -> NodeSnapshot:
        return cls(
            time.perf_counter(),
            node.steps,
            {name: node.timings[name].count for name in HEAVY_SENSORS},
            {name: node.timings[name].skipped for name in HEAVY_SENSORS},
        )


def configured_rates_hz(cfg: SimConfig) -> dict[str, float]:
    """Each topic's configured rate (the catalogue's rate key; IMU, odometry and tf: the
    physics rate)."""
    return {key: config_value(cfg, CATALOGUE[key].rate_key) for key in TOPICS}


def stamp_rate_hz(stamps_s: list[float]) -> float:
    """Messages per second between the first and last capture stamp (0 below two)."""
    if len(stamps_s) < 2 or stamps_s[-1] <= stamps_s[0]:
        return 0.0
    return (len(stamps_s) - 1) / (stamps_s[-1] - stamps_s[0])


async def realtime_run(
    url: str, cfg: SimConfig, scene: Scene, seconds: float
) -> tuple[NodeSnapshot, NodeSnapshot, dict[str, list[float]], SteppingNode]:
    """Run the node against `url` for warm-up + `seconds`; counters at both ends of the
    measured window and the capture stamps (s) a listener received within it."""
    stamps: dict[str, list[float]] = {name: [] for name in TOPICS}
    recording = asyncio.Event()
    async with (
        RosbridgeClient(url, name="simulator") as client,
        RosbridgeClient(url, name="listener") as listener,
    ):
        subs = {
            name: await listener.subscribe(topic, type_name, maxsize=10_000)
            for name, (topic, type_name) in TOPICS.items()
        }

        async def consume(name: str) -> None:
            async for received in subs[name]:
                if recording.is_set():
                    stamps[name].append(header_stamp_s(received.msg))

        node, stop = SteppingNode(client, cfg, scene), asyncio.Event()
        tasks = [asyncio.create_task(node.run(stop))]
        tasks += [asyncio.create_task(consume(name)) for name in subs]
        try:
            await asyncio.sleep(RTF_WARMUP_S)
            recording.set()
            first = NodeSnapshot.of(node)
            await asyncio.sleep(seconds)
            last = NodeSnapshot.of(node)
        finally:
            stop.set()
            await tasks[0]
            for task in tasks[1:]:
                task.cancel()
            await asyncio.gather(*tasks[1:], return_exceptions=True)
    return first, last, stamps, node


def report_realtime(
    cfg: SimConfig,
    first: NodeSnapshot,
    last: NodeSnapshot,
    stamps: dict[str, list[float]],
    node: SteppingNode,
) -> None:
    wall_s = last.wall_s - first.wall_s
    simulated_s = (last.steps - first.steps) / cfg.vessel.physics_rate_hz
    rtf = simulated_s / wall_s
    verdict = "ok" if abs(rtf - 1.0) <= RTF_TOLERANCE else "OUT OF TOLERANCE"
    print(
        f"\nreal-time factor: simulated {simulated_s:.2f} s / wall {wall_s:.2f} s = "
        f"{rtf:.4f} (target 1.00 +- {RTF_TOLERANCE}: {verdict}); physics lateness "
        f"{node.physics_lateness.summary()} (last 200 ticks)"
    )
    print(
        f"{'topic':<7} {'configured':>10} {'generated':>10} {'received':>9} {'msgs':>5} "
        f"{'skipped':>7}  generation (last 200)"
    )
    for name, hz in configured_rates_hz(cfg).items():
        if name in HEAVY_SENSORS:
            generated = f"{(last.generated[name] - first.generated[name]) / wall_s:10.3f}"
            skipped = f"{last.skipped[name] - first.skipped[name]:7d}"
            timing = node.timings[name].summary()
        else:
            generated, skipped, timing = f"{'-':>10}", f"{'-':>7}", ""
        received = stamp_rate_hz(stamps[name])
        print(
            f"{name:<7} {hz:10.3f} {generated} {received:9.3f} {len(stamps[name]):5d} "
            f"{skipped}  {timing}"
        )
    print(
        "generated = sensor messages made per wall second; received = rate of capture "
        "stamps a listener got through the bridge; skipped = sensor ticks missed by overrun"
    )


def run_realtime(seconds: float, cfg: SimConfig, scene: Scene) -> None:
    """The whole simulator in real time against `python -m bridge`, every sensor on."""
    print(
        f"\n## whole simulator, {seconds:g} s after {RTF_WARMUP_S:g} s warm-up, default "
        f"config (every sensor at its rate), against `python -m bridge`; load average "
        f"{os.getloadavg()[0]:.2f}"
    )
    with running_bridge() as (_, url):
        first, last, stamps, node = asyncio.run(realtime_run(url, cfg, scene, seconds))
    report_realtime(cfg, first, last, stamps, node)


def core_benchmarks(args: argparse.Namespace, scene: Scene) -> None:
    """Per-call times of each sensor and the physics step, paired with the load reference."""
    poses = poses_along_the_river(scene.start_pose, args.repeat + 3)
    lidar, camera, radar = Lidar(threads=args.threads), Camera(threads=args.threads), Radar()
    reference_pool = ThreadPoolExecutor(2, "reference")
    reference = reference_query(scene, lidar, reference_pool)
    try:
        points_seen: list[int] = []

        def lidar_scan(i: int) -> None:
            points = lidar.scan(scene, poses[i])
            lidar.message(points, stamp_ns=i)
            points_seen.append(len(points))

        report(
            "lidar scan",
            paired_times_ms(lidar_scan, reference, args.repeat),
            f"{lidar.ray_count:,} rays, median {statistics.median(points_seen):,.0f} points",
        )
        jpeg_bytes: list[int] = []

        def camera_frame(i: int) -> None:
            jpeg = camera.encode(camera.render(scene, poses[i]))
            camera.message(jpeg, stamp_ns=i)
            jpeg_bytes.append(len(jpeg))

        report(
            "camera frame",
            paired_times_ms(camera_frame, reference, args.repeat),
            f"640x480, JPEG median {statistics.median(jpeg_bytes) / 1e3:.0f} kB",
        )
        report(
            "radar sweep",
            paired_times_ms(
                lambda i: radar.message(radar.sweep(scene, poses[i]), stamp_ns=i),
                reference,
                args.repeat,
            ),
            f"{len(radar.geometry.directions_sensor):,} rays",
        )
    finally:
        lidar.close()
        camera.close()
        radar.close()
    dynamics, imu = VesselDynamics(scene=scene), Imu()
    state = [VesselState.at(scene.start_pose)]

    def imu_steps(i: int) -> None:
        """50 physics steps, each with its IMU message (timed together, reported per step)."""
        for k in range(50):
            result = dynamics.step(state[0], Command(1500.0, 200.0))
            state[0] = result.state
            imu.message(imu.measure(result), stamp_ns=50 * i + k)

    steps, refs = paired_times_ms(imu_steps, reference, args.repeat)
    report(
        "imu step",
        ([t / 50 for t in steps], refs),
        "physics RK4 + collision rays + IMU reading + message",
    )
    reference_pool.shutdown()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    parser.add_argument("--threads", type=int, default=2, help="ray-casting threads per sensor")
    parser.add_argument(
        "--tuned-malloc",
        action="store_true",
        help="re-run under the glibc malloc thresholds that avoid page faults",
    )
    parser.add_argument(
        "--rtf-seconds",
        type=float,
        default=30.0,
        help="length of the real-time run with every sensor on (0: skip it)",
    )
    parser.add_argument(
        "--quick", action="store_true", help="a short run: 5 repeats and a 5 s real-time run"
    )
    parser.add_argument(
        "--multithreaded-blas",
        action="store_true",
        help="leave OpenBLAS its default threads (every riverbridge process "
        "limits it to one; this shows what that saves)",
    )
    args = parser.parse_args(argv)
    if not args.multithreaded_blas:
        single_threaded_blas()
    if args.tuned_malloc and not malloc_tuned():
        rerun_tuned(__spec__.name, sys.argv[1:])
    if args.quick:
        args.repeat, args.rtf_seconds = min(args.repeat, 5), min(args.rtf_seconds, 5.0)
    cfg = SimConfig()
    start = time.perf_counter()
    scene = build_scene(cfg.scene, seed=cfg.seed)
    print(
        f"scene: {scene.triangle_count:,} triangles, built in "
        f"{time.perf_counter() - start:.2f} s; threads {args.threads}; malloc "
        f"{'tuned' if os.environ.get('MALLOC_MMAP_THRESHOLD_') else 'default'}; "
        f"{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f}"
    )
    core_benchmarks(args, scene)
    if args.rtf_seconds > 0:
        run_realtime(args.rtf_seconds, cfg, scene)
    print(f"load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
