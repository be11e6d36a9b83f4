"""The simulator's edge: the numeric core on fixed schedules, published through rosbridge.

Physics runs at `vessel.physics_rate_hz` on the event loop (one RK4 step is ~0.1 ms) and keeps
real time by stepping as often as the wall clock demands; every step publishes the IMU, ground
truth odometry and the vessel transform. Each heavy sensor (LIDAR, radar, camera) has its own
schedule and its own worker thread (plus its ray-casting threads; Embree, numpy and OpenCV
release the GIL), so the IMU never waits behind a scan. A sensor that overruns its period skips
the missed ticks instead of queueing them. All sensor topics are advertised `latest_only`, so a
publish never blocks the schedule. The small, frequent messages travel on a connection of their
own, so they never queue on the wire behind a scan. Per-sensor generation times are logged
periodically. With `[ground_truth] enabled`, the scene's objects go out once (latched) and
every LIDAR scan and radar sweep is followed by what it saw (simulator.truth).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import statistics
import time
from collections import deque
from collections.abc import Awaitable, Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from clients import RosbridgeClient
from clients.node_links import node_links
from clients.protocol import Encoding
from clients.tracing import Tracer
from schemas.process_tuning import background_priority
from simulator.camera import OPTICAL_TO_BODY, Camera
from simulator.config import MountConfig, SimConfig
from simulator.dynamics import Command, StepResult, VesselDynamics, VesselState
from simulator.frames import mount_rotation, quaternion_from_matrix
from simulator.gnss import Gnss
from simulator.imu import Imu
from simulator.lidar import Lidar
from simulator.messages import BASE_FRAME, odometry, tf_message, transform_stamped, vessel_tf
from simulator.radar import Radar
from simulator.scene import Scene, build_scene
from simulator.truth import MARKERS_TYPE, TRUTH_TYPE, lidar_truth, markers_msg, radar_truth

log = logging.getLogger(__name__)


TOPICS = {
    "lidar": ("/lidar/points", "sensor_msgs/msg/PointCloud2"),
    "radar": ("/radar/image", "riverbridge_msgs/msg/RadarImage"),
    "camera": ("/camera/image/compressed", "sensor_msgs/msg/CompressedImage"),
    "imu": ("/imu/data", "sensor_msgs/msg/Imu"),
    "gnss": ("/gnss/fix", "sensor_msgs/msg/NavSatFix"),
    "odom": ("/odom", "nav_msgs/msg/Odometry"),
    "tf": ("/tf", "tf2_msgs/msg/TFMessage"),
}
TF_STATIC = ("/tf_static", "tf2_msgs/msg/TFMessage")
GROUND_TRUTH = ("/sim/ground_truth", MARKERS_TYPE)
# The effective configuration as JSON (latched), so a recording or a report knows what ran.
SIM_CONFIG = ("/sim/config", "std_msgs/msg/String")
TRUTH_TOPICS = {"lidar": "/sim/ground_truth/lidar", "radar": "/sim/ground_truth/radar"}
COMMAND = ("/cmd_wrench", "geometry_msgs/msg/Wrench")
HEAVY_SENSORS = ("lidar", "radar", "camera")
STATS_PERIOD_S = 10.0
MAX_CATCH_UP_STEPS = 25  # after a long stall, jump ahead rather than spin through the backlog
# The truth of a scan goes out this long after the scan: not while the bridge is still handing
# the scan on (its loop would decode and fan out the truth in the scan's way); it is stamped
# with the scan's capture time, so a judge pairs it all the same.
TRUTH_DELAY_S = 0.1
# A sensor tick's work: its message first, then (topic, message) pairs of ground truth.
Outputs = list[Any]


class GenerationTimes:
    """Rolling generation times (ms) of one sensor, plus how many ticks it skipped."""

    def __init__(self, window: int = 200) -> None:
        self.times_ms: deque[float] = deque(maxlen=window)
        self.count = 0
        self.skipped = 0

    def record(self, ms: float) -> None:
        self.times_ms.append(ms)
        self.count += 1

    def summary(self) -> str:
        if not self.times_ms:
            return f"n={self.count} skipped={self.skipped}"
        return (f"n={self.count} median={statistics.median(self.times_ms):.1f} ms "
                f"max={max(self.times_ms):.1f} ms skipped={self.skipped}")


def static_transforms(cfg: SimConfig, stamp_ns: int) -> dict:
    """TFMessage base_link -> every sensor frame, from the mounts (camera: optical frame)."""
    sensors: list[tuple[str, MountConfig, Any]] = [
        (cfg.lidar.frame_id, cfg.lidar.mount, None),
        (cfg.radar.frame_id, cfg.radar.mount, None),
        (cfg.camera.frame_id, cfg.camera.mount, OPTICAL_TO_BODY),
        (cfg.imu.frame_id, cfg.imu.mount, None),
        (cfg.gnss.frame_id, cfg.gnss.mount, None),
    ]
    transforms = []
    for frame_id, mount, extra in sensors:
        rotation = mount_rotation(mount) if extra is None else mount_rotation(mount) @ extra
        transforms.append(transform_stamped(stamp_ns, BASE_FRAME, frame_id,
                                            (mount.x_m, mount.y_m, mount.z_m),
                                            quaternion_from_matrix(rotation)))
    return tf_message(transforms)


class SimulatorNode:
    """Runs the simulation against connected clients until `stop` is set.

    client : carries the bulk sensor data (LIDAR, radar, camera) and /tf_static.
    realtime : carries the small, frequent messages (IMU, odometry, tf, GNSS, commands); by
        default `client`. On its own connection an IMU sample never waits on the wire behind
        a 4 MB scan (one TCP stream delivers in order: up to 5 ms per hop here).
    clock_ns : wall clock for capture stamps (injectable for tests).
    tracer : records each sensor message's `generate` stage (capture → message ready).
    """

    def __init__(self, client: RosbridgeClient, cfg: SimConfig, scene: Scene, *,
                 realtime: RosbridgeClient | None = None,
                 clock_ns: Callable[[], int] = time.time_ns,
                 tracer: Tracer | None = None) -> None:
        self._client = client
        self._realtime = realtime or client
        self._tracer = tracer
        self.cfg = cfg
        self.scene = scene
        self._clock_ns = clock_ns
        self.dynamics = VesselDynamics(cfg.vessel, scene)
        self.state = VesselState.at(scene.start_pose)
        self.command = Command()
        self.collisions = 0
        self.lidar = Lidar(cfg.lidar, threads=2, seed=cfg.seed + 1)
        self.radar = Radar(cfg.radar, seed=cfg.seed + 2)
        self.camera = Camera(cfg.camera, threads=2)
        self.imu = Imu(cfg.imu, seed=cfg.seed + 3)
        self.gnss = Gnss(cfg.gnss, seed=cfg.seed + 4)
        self.timings = {name: GenerationTimes() for name in (*HEAVY_SENSORS, "physics")}
        self.physics_lateness = GenerationTimes()  # ms each physics tick started behind schedule
        self._truth_tasks: set[asyncio.Task[None]] = set()
        self._executors = {name: ThreadPoolExecutor(1, thread_name_prefix=f"sim-{name}",
                                                    initializer=background_priority)
                           for name in HEAVY_SENSORS}

    async def run(self, stop: asyncio.Event) -> None:
        """Advertise, subscribe to commands, run every schedule until `stop`, then clean up."""
        for name, (topic, type_name) in TOPICS.items():
            await self._client_for(name).advertise(topic, type_name, latest_only=True)
        await self._client.advertise(*TF_STATIC, latch=True)
        await self._client.publish(TF_STATIC[0], static_transforms(self.cfg, self._clock_ns()))
        await self._client.advertise(*SIM_CONFIG, latch=True)
        await self._client.publish(SIM_CONFIG[0], {"data": self.cfg.model_dump_json()})
        if self.cfg.ground_truth.enabled:
            await self._advertise_truth()
        commands = await self._realtime.subscribe(*COMMAND, maxsize=1)
        generators = {"lidar": self._lidar, "radar": self._radar, "camera": self._camera}
        rates = {"lidar": self.cfg.lidar.rate_hz, "radar": self.cfg.radar.rate_hz,
                 "camera": self.cfg.camera.rate_hz}
        tasks = [asyncio.create_task(self._physics()), asyncio.create_task(self._follow(commands))]
        # Stagger the heavy sensors over their period so their ray casts rarely overlap.
        tasks += [asyncio.create_task(_every(1.0 / rates[name], self._sensor_tick(name, work),
                                             self.timings[name], phase=k / len(generators)))
                  for k, (name, work) in enumerate(generators.items())]
        tasks += [asyncio.create_task(_every(1.0 / self.cfg.gnss.rate_hz, self._publish_gnss)),
                  asyncio.create_task(_every(STATS_PERIOD_S, self._log_timings))]
        try:
            await stop.wait()
        finally:
            for task in [*tasks, *self._truth_tasks]:
                task.cancel()
            for task in [*tasks, *self._truth_tasks]:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
            for executor in self._executors.values():
                executor.shutdown(wait=True, cancel_futures=True)
            for sensor in (self.lidar, self.radar, self.camera):
                sensor.close()

    async def _advertise_truth(self) -> None:
        for topic in TRUTH_TOPICS.values():
            await self._client.advertise(topic, TRUTH_TYPE, latest_only=True)
        await self._client.advertise(*GROUND_TRUTH, latch=True)
        await self._client.publish(GROUND_TRUTH[0],
                                   markers_msg(self.scene.objects, self._clock_ns()))

    def _client_for(self, sensor: str) -> RosbridgeClient:
        return self._client if sensor in HEAVY_SENSORS else self._realtime

    async def _follow(self, commands) -> None:
        """Keep the newest `/cmd_wrench` as the actuator command."""
        async for received in commands:
            try:
                self.command = Command.from_wrench(received.msg)
            except (KeyError, TypeError, ValueError):
                log.exception("ignoring a malformed %s message", COMMAND[0])

    async def _physics(self) -> None:
        """Step the vessel in real time at the fixed physics rate; publish IMU, odom and tf."""
        loop = asyncio.get_running_loop()
        dt_s = self.dynamics.dt_s
        start_s, steps_done = loop.time(), 0
        while True:
            now_s = loop.time()
            self.physics_lateness.record(max(0.0, now_s - (start_s + steps_done * dt_s)) * 1e3)
            due = int((now_s - start_s) / dt_s) + 1 - steps_done
            if due > MAX_CATCH_UP_STEPS:
                log.warning("physics fell %d steps behind; skipping ahead", due)
                steps_done += due - 1
                due = 1
            started = time.perf_counter()
            # A late tick publishes every step it catches up on, each stamped at its own step
            # time, yielding in between so the latest-only senders take each message.
            now_ns, dt_ns = self._clock_ns(), round(dt_s * 1e9)
            for k in range(due):
                await self._publish_physics(self._step(), now_ns - (due - 1 - k) * dt_ns)
                if k < due - 1:
                    await asyncio.sleep(0)
            steps_done += due
            self.timings["physics"].record((time.perf_counter() - started) * 1e3)
            await asyncio.sleep(max(0.0, start_s + steps_done * dt_s - loop.time()))

    def _step(self) -> StepResult:
        result = self.dynamics.step(self.state, self.command)
        self.state = result.state
        if result.collided:
            self.collisions += 1
        return result

    async def _publish_physics(self, result: StepResult, stamp_ns: int) -> None:
        state, water_m = result.state, self.scene.water_level_m
        imu_msg = self.imu.message(self.imu.measure(result), stamp_ns)
        self._generated(TOPICS["imu"][0], stamp_ns)
        await self._realtime.publish(TOPICS["imu"][0], imu_msg)
        await self._realtime.publish(TOPICS["odom"][0], odometry(
            state.pose, water_m, (state.u_mps, state.v_mps), state.r_radps, stamp_ns))
        await self._realtime.publish(TOPICS["tf"][0], vessel_tf(state.pose, water_m, stamp_ns))

    def _sensor_tick(self, name: str, work: Callable[[Any, int], Outputs]):
        """A tick that captures pose and stamp now, generates on the sensor's thread, publishes
        the sensor's message, and any ground truth that came with it TRUTH_DELAY_S later."""
        loop = asyncio.get_running_loop()

        async def tick() -> None:
            pose, stamp_ns = self.state.pose, self._clock_ns()
            started = time.perf_counter()
            msg, *truth = await loop.run_in_executor(self._executors[name], work, pose, stamp_ns)
            self.timings[name].record((time.perf_counter() - started) * 1e3)
            self._generated(TOPICS[name][0], stamp_ns)
            await self._client.publish(TOPICS[name][0], msg)
            if truth:
                task = asyncio.create_task(self._publish_truth(truth))
                self._truth_tasks.add(task)
                task.add_done_callback(self._truth_tasks.discard)

        return tick

    async def _publish_truth(self, truth: Outputs) -> None:
        await asyncio.sleep(TRUTH_DELAY_S)
        for topic, msg in truth:
            await self._client.publish(topic, msg)

    def _generated(self, topic: str, stamp_ns: int) -> None:
        """Trace `generate`: capture (the stamp) → message ready (now)."""
        if self._tracer is not None:
            self._tracer.record(topic, stamp_ns, "generate", stamp_ns, self._clock_ns())

    def _lidar(self, pose, stamp_ns: int) -> Outputs:
        if not self.cfg.ground_truth.enabled:
            return [self.lidar.message(self.lidar.scan(self.scene, pose), stamp_ns)]
        scan = self.lidar.scan_with_sources(self.scene, pose)
        truth = lidar_truth(self.scene, self.cfg.lidar, pose, scan.source, stamp_ns)
        return [self.lidar.message(scan.points, stamp_ns), (TRUTH_TOPICS["lidar"], truth)]

    def _radar(self, pose, stamp_ns: int) -> Outputs:
        if not self.cfg.ground_truth.enabled:
            return [self.radar.message(self.radar.sweep(self.scene, pose), stamp_ns)]
        sweep = self.radar.sweep_with_sources(self.scene, pose)
        truth = radar_truth(self.scene, self.cfg.radar, pose, sweep, stamp_ns)
        return [self.radar.message(sweep.image, stamp_ns), (TRUTH_TOPICS["radar"], truth)]

    def _camera(self, pose, stamp_ns: int) -> Outputs:
        return [self.camera.message(self.camera.encode(self.camera.render(self.scene, pose)),
                                    stamp_ns)]

    async def _publish_gnss(self) -> None:
        fix = self.gnss.fix(self.state.pose, self.scene.water_level_m)
        await self._realtime.publish(TOPICS["gnss"][0], self.gnss.message(fix, self._clock_ns()))

    async def _log_timings(self) -> None:
        log.info("generation times: %s; physics lateness %s; collisions %d", "; ".join(
            f"{name} {times.summary()}" for name, times in self.timings.items()),
            self.physics_lateness.summary(), self.collisions)


async def _every(period_s: float, action: Callable[[], Awaitable[None]],
                 times: GenerationTimes | None = None, phase: float = 0.0) -> None:
    """Call `action` every `period_s` on a fixed schedule, the first call `phase` periods from
    now. After an overrun the next tick starts at once (late, its own stamp), so a scan that
    just misses its period costs no tick; only ticks a whole period behind are skipped (and
    counted in `times.skipped`), never queued. Runs until cancelled."""
    loop = asyncio.get_running_loop()
    next_s = loop.time() + phase * period_s
    await asyncio.sleep(phase * period_s)
    while True:
        try:
            await action()
        except Exception:  # one failed tick must not end the schedule
            log.exception("periodic %s failed", getattr(action, "__qualname__", action))
        next_s += period_s
        behind = loop.time() - next_s
        if behind >= period_s:
            missed = int(behind / period_s)
            next_s += missed * period_s
            if times is not None:
                times.skipped += missed
        await asyncio.sleep(max(0.0, next_s - loop.time()))


async def serve(url: str, cfg: SimConfig, stop: asyncio.Event, *, encoding: Encoding = "cbor",
                scene: Scene | None = None, connect_timeout_s: float = 10.0) -> None:
    """Build the scene (off the event loop), connect to the bridge at `url`, run until `stop`."""
    if scene is None:
        scene = await asyncio.to_thread(build_scene, cfg.scene, seed=cfg.seed)
    async with node_links(url, "simulator", encoding=encoding,
                          connect_timeout_s=connect_timeout_s) as links:
        log.info("simulator connected to %s (%s, bulk and realtime connections); %d triangles",
                 url, encoding, scene.triangle_count)
        await SimulatorNode(links.bulk, cfg, scene, realtime=links.realtime,
                            tracer=links.tracer).run(stop)
