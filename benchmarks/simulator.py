"""Benchmark of the simulator's numeric core against its per-sensor time budgets.

Run: `python benchmarks/simulator.py [--repeat 30] [--threads 2] [--tuned-malloc]`

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
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from simulator.camera import Camera
from simulator.dynamics import Command, VesselDynamics, VesselState
from simulator.frames import Pose2D, rotate_rows, sensor_pose_in_map
from simulator.imu import Imu
from simulator.lidar import Lidar
from simulator.radar import Radar
from simulator.scene import Scene, build_scene

# Targets on 2 cores (issue 3). LIDAR and camera come from the brief; the RADAR and IMU budgets
# are 1 % of the 500 ms sweep period and 5 % of the 20 ms physics period.
TARGETS_MS = {"lidar scan": 30.0, "camera frame": 40.0, "radar sweep": 5.0, "imu step": 1.0}
QUIET_REFERENCE_MS = 20.2  # performance-measurements.md 2(d): DISTANCE on 2 threads, median
TUNED_MALLOC = {  # performance-measurements.md, page-fault note
    "MALLOC_MMAP_THRESHOLD_": "268435456",
    "MALLOC_TRIM_THRESHOLD_": "1073741824",
    "MALLOC_TOP_PAD_": "67108864",
}


def reference_query(scene: Scene, lidar: Lidar, pool: ThreadPoolExecutor) -> Callable[[], object]:
    """The DISTANCE query of every LIDAR ray from the start pose, in two halves on `pool`."""
    origin, rotation = sensor_pose_in_map(scene.start_pose, lidar.cfg.mount, scene.water_level_m)
    directions = np.empty_like(lidar.directions_sensor)
    rotate_rows(lidar.directions_sensor, rotation, directions)
    origins = np.ascontiguousarray(np.broadcast_to(origin.astype(np.float32), directions.shape))
    half = len(directions) // 2
    halves = [slice(0, half), slice(half, len(directions))]

    def query() -> None:
        futures = [pool.submit(scene.embree.run, origins[h], directions[h], query="DISTANCE")
                   for h in halves]
        for future in futures:
            future.result()

    return query


def paired_times_ms(work: Callable[[int], object], reference: Callable[[], object],
                    repeat: int, warmup: int = 3) -> tuple[list[float], list[float]]:
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
    return [Pose2D(start.x_m + 0.5 * k, start.y_m + 2.0 * k, start.yaw_rad + 0.01 * k)
            for k in range(count)]


def report(name: str, times: tuple[list[float], list[float]], extra: str = "") -> None:
    wall = sorted(times[0])
    median = statistics.median(wall)
    p90 = wall[int(0.9 * (len(wall) - 1))]
    load = statistics.median(times[1]) / QUIET_REFERENCE_MS
    target = TARGETS_MS[name]
    verdict = "ok" if median <= target else "OVER"
    print(f"{name:<13} min {wall[0]:7.2f}  median {median:7.2f}  p90 {p90:7.2f} ms | "
          f"target {target:5.1f} ratio {median / target:5.2f} {verdict:<4} | "
          f"load {load:4.2f} quiet est. {median / load:6.2f} ms | {extra}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=30)
    parser.add_argument("--threads", type=int, default=2, help="ray-casting threads per sensor")
    parser.add_argument("--tuned-malloc", action="store_true",
                        help="re-run under the glibc malloc thresholds that avoid page faults")
    args = parser.parse_args(argv)
    if args.tuned_malloc and not all(os.environ.get(k) == v for k, v in TUNED_MALLOC.items()):
        os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, **TUNED_MALLOC})

    start = time.perf_counter()
    scene = build_scene()
    print(f"scene: {scene.triangle_count:,} triangles, built in "
          f"{time.perf_counter() - start:.2f} s; threads {args.threads}; malloc "
          f"{'tuned' if os.environ.get('MALLOC_MMAP_THRESHOLD_') else 'default'}; "
          f"{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f}")
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

        report("lidar scan", paired_times_ms(lidar_scan, reference, args.repeat),
               f"{lidar.ray_count:,} rays, median {statistics.median(points_seen):,.0f} points")
        jpeg_bytes: list[int] = []

        def camera_frame(i: int) -> None:
            jpeg = camera.encode(camera.render(scene, poses[i]))
            camera.message(jpeg, stamp_ns=i)
            jpeg_bytes.append(len(jpeg))

        report("camera frame", paired_times_ms(camera_frame, reference, args.repeat),
               f"640x480, JPEG median {statistics.median(jpeg_bytes) / 1e3:.0f} kB")
        report("radar sweep", paired_times_ms(
            lambda i: radar.message(radar.sweep(scene, poses[i]), stamp_ns=i), reference,
            args.repeat), f"{len(radar.geometry.directions_sensor):,} rays")
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
    report("imu step", ([t / 50 for t in steps], refs),
           "physics RK4 + collision rays + IMU reading + message")
    reference_pool.shutdown()
    print(f"load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
