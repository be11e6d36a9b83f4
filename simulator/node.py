"""The simulator's edge: its sensors on fixed schedules, published through rosbridge.

Physics runs at `vessel.physics_rate_hz` on the event loop (one RK4 step is ~0.1 ms) and keeps
real time by stepping as often as the wall clock demands. The node loops over its sensors
(simulator.sensors; what a sensor is: simulator.sensor) and runs each on its schedule: the
physics sensors (IMU, odometry, tf) after every step; a timer sensor (GNSS) on the event loop
at its rate; each worker sensor (LIDAR, radar, camera) on its own schedule and worker thread
(plus its ray-casting threads; Embree, numpy and OpenCV release the GIL), so the IMU never
waits behind a scan. A sensor that overruns its period skips the missed ticks instead of
queueing them. Topics come from schemas.catalogue; every sensor topic is advertised
`latest_only`, so a publish never blocks the schedule. Realtime topics travel on a connection
of their own, so they never queue on the wire behind a scan. Per-sensor generation times are
logged periodically. With `[ground_truth] enabled`, the scene's objects go out once (latched)
and every LIDAR scan and radar sweep is followed by what it saw (simulator.truth).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import statistics
import time
from collections import deque
from collections.abc import Awaitable, Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from clients import RosbridgeClient, Subscription
from clients.node.links import node_links
from clients.protocol import Encoding
from clients.tracing import Tracer
from schemas.catalogue import TOPICS, Topic, period_s, published_by
from schemas.runtime.periodic import every
from schemas.runtime.process import background_priority
from schemas.tracing import header_stamp_ns
from simulator.command import CommandArbiter
from simulator.config import SimConfig
from simulator.dynamics import Command, StepResult, VesselDynamics, VesselState
from simulator.messages import header
from simulator.scene import Scene, build_scene
from simulator.sensor import Capture, Generated, Sensor, config_value
from simulator.sensors import build_sensors, static_transforms
from simulator.truth import markers_msg

log = logging.getLogger(__name__)

STATS_PERIOD_S = 10.0
MAX_CATCH_UP_STEPS = 25  # after a long stall, jump ahead rather than spin through the backlog
# The truth of a scan goes out this long after the scan: not while the bridge is still handing
# the scan on (its loop would decode and fan out the truth in the scan's way); it is stamped
# with the scan's capture time, so a judge pairs it all the same.
TRUTH_DELAY_S = 0.1


class GenerationTimes:
    """Rolling generation times (ms) of one sensor, plus how many ticks it skipped."""

    def __init__(self, window: int = 200) -> None:
        self.times_ms: deque[float] = deque(maxlen=window)
        self.count = 0
        self.skipped = 0

    def record(self, ms: float) -> None:
        self.times_ms.append(ms)
        self.count += 1

    def skip(self, ticks: int) -> None:
        """The schedule fell `ticks` whole periods behind and dropped them."""
        self.skipped += ticks

    def summary(self) -> str:
        if not self.times_ms:
            return f"n={self.count} skipped={self.skipped}"
        return (
            f"n={self.count} median={statistics.median(self.times_ms):.1f} ms "
            f"max={max(self.times_ms):.1f} ms skipped={self.skipped}"
        )


class SimulatorNode:
    """Runs the simulation against connected clients until `stop` is set.

    client : carries the bulk sensor data (role "sensor": LIDAR, radar, camera), the latched
        topics and the ground truth.
    realtime : carries the small, frequent messages (role "realtime": IMU, odometry, tf, GNSS)
        and the commands; by default `client`. On its own connection an IMU sample never waits
        on the wire behind a 4 MB scan (one TCP stream delivers in order: up to 5 ms per hop).
    clock_ns : wall clock for capture stamps (injectable for tests).
    tracer : records the `generate` stage (capture -> message ready) of the thesis's sensors.
    sensors : what to run; by default simulator.sensors.SENSORS built for `cfg` and `scene`.
    """

    def __init__(
        self,
        client: RosbridgeClient,
        cfg: SimConfig,
        scene: Scene,
        *,
        realtime: RosbridgeClient | None = None,
        clock_ns: Callable[[], int] = time.time_ns,
        tracer: Tracer | None = None,
        sensors: Sequence[Sensor] | None = None,
    ) -> None:
        self._client = client
        self._realtime = realtime or client
        self._tracer = tracer
        self.cfg = cfg
        self.scene = scene
        self._clock_ns = clock_ns
        self.dynamics = VesselDynamics(cfg.vessel, scene)
        self.latest_step = StepResult(VesselState.at(scene.start_pose), (0.0, 0.0), 0.0, False)
        self.commands = CommandArbiter(cfg.command)
        self.collisions = 0  # physics steps spent against an obstacle
        self.collision_events = 0  # times the hull met one (a run of such steps is one)
        self.sensors = list(sensors) if sensors is not None else build_sensors(cfg, scene)
        self._physics_sensors = [s for s in self.sensors if s.schedule == "physics"]
        self._workers = [s for s in self.sensors if s.schedule == "worker"]
        keys = [s.topic.key for s in self._workers]
        self.timings = {key: GenerationTimes() for key in (*keys, "physics")}
        self.physics_lateness = GenerationTimes()  # ms each physics tick started behind schedule
        self._truth_tasks: set[asyncio.Task[None]] = set()
        self._executors = {
            key: ThreadPoolExecutor(
                1, thread_name_prefix=f"sim-{key}", initializer=background_priority
            )
            for key in keys
        }

    @property
    def state(self) -> VesselState:
        """The vessel after the latest physics step."""
        return self.latest_step.state

    def rate_hz(self, sensor: Sensor) -> float:
        """How often `sensor` runs: its catalogue topic's rate key in this configuration."""
        return float(config_value(self.cfg, sensor.topic.rate_key))

    async def run(self, stop: asyncio.Event) -> None:
        """Advertise, subscribe to commands, run every schedule until `stop`, then clean up."""
        await self._advertise()
        operator = await self._realtime.subscribe(*TOPICS["cmd_wrench"].pair, maxsize=1)
        autopilot = await self._realtime.subscribe(*TOPICS["guidance_cmd"].pair, maxsize=1)
        await self._realtime.advertise(*TOPICS["sim_status"].pair)
        tasks = [
            asyncio.create_task(self._physics()),
            asyncio.create_task(self._follow(operator)),
            asyncio.create_task(self._follow(autopilot)),
            asyncio.create_task(every(period_s("sim_status"), self._publish_status)),
        ]
        # Stagger the worker sensors over their period so their ray casts rarely overlap.
        for k, sensor in enumerate(self._workers):
            tasks.append(
                asyncio.create_task(
                    every(
                        1.0 / self.rate_hz(sensor),
                        self._worker_tick(sensor),
                        phase=k / len(self._workers),
                        on_skipped=self.timings[sensor.topic.key].skip,
                    )
                )
            )
        tasks += [
            asyncio.create_task(every(1.0 / self.rate_hz(sensor), self._timer_tick(sensor)))
            for sensor in self.sensors
            if sensor.schedule == "timer"
        ]
        tasks.append(asyncio.create_task(every(STATS_PERIOD_S, self._log_timings)))
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
            for sensor in self.sensors:
                sensor.close()

    async def _advertise(self) -> None:
        """Every sensor topic (latest-only), then the latched set-up: sensor mounts, the
        effective configuration and, with ground truth, the scene's objects and the per-scan
        truth topics."""
        for sensor in self.sensors:
            await self._link(sensor.topic).advertise(*sensor.topic.pair, latest_only=True)
        now_ns = self._clock_ns()
        await self._publish_latched(TOPICS["tf_static"], static_transforms(self.sensors, now_ns))
        await self._publish_latched(TOPICS["sim_config"], {"data": self.cfg.model_dump_json()})
        if self.cfg.ground_truth.enabled:
            for topic in published_by("simulator", "truth"):
                if not topic.latched:
                    await self._client.advertise(*topic.pair, latest_only=True)
            await self._publish_latched(
                TOPICS["ground_truth"], markers_msg(self.scene.objects, now_ns)
            )

    async def _publish_latched(self, topic: Topic, msg: dict[str, Any]) -> None:
        await self._client.advertise(*topic.pair, latch=True)
        await self._client.publish(topic.name, msg)

    def _link(self, topic: Topic) -> RosbridgeClient:
        """The connection a topic travels on: realtime ones never behind a scan."""
        return self._realtime if topic.role == "realtime" else self._client

    async def _follow(self, commands: Subscription) -> None:
        """Hand each command to the arbiter: a person's `/cmd_wrench` or the autopilot's
        stamped `/guidance/cmd_wrench` (simulator.command decides which one drives)."""
        autopilot = commands.topic == TOPICS["guidance_cmd"].name
        async for received in commands:
            try:
                if autopilot:
                    msg = received.msg
                    stamp_ns = header_stamp_ns(msg)
                    if stamp_ns is None:
                        raise ValueError("no header.stamp")
                    command = Command.from_wrench(msg["wrench"])
                    received_ns = self._received_ns(commands.topic, stamp_ns)
                    self.commands.autopilot(command, stamp_ns, received_ns)
                else:
                    self.commands.operator(Command.from_wrench(received.msg), self._clock_ns())
            except (KeyError, TypeError, ValueError) as exc:
                log.warning("ignoring a malformed %s message: %s", commands.topic, exc)

    def _received_ns(self, topic: str, stamp_ns: int) -> int:
        """When `(topic, stamp_ns)` was decoded here (the tracer remembers), else now."""
        now_ns = self._clock_ns()
        return now_ns if self._tracer is None else self._tracer.decoded_ns(topic, stamp_ns, now_ns)

    @property
    def command(self) -> Command:
        """The command the next physics step applies."""
        return self.commands.current(self._clock_ns())[0]

    async def _publish_status(self) -> None:
        """/sim/status: who drives, command timeouts and overrides, collisions."""
        arbiter = self.commands
        values = {
            "source": arbiter.source,
            "command_timeouts": arbiter.timeouts,
            "operator_overrides": arbiter.overrides,
            "collisions": self.collision_events,
            "collision_steps": self.collisions,
        }
        status = {
            "level": 1 if arbiter.source == "none" else 0,
            "name": "simulator/command",
            "message": f"{arbiter.source} commands the vessel",
            "hardware_id": "",
            "values": [{"key": k, "value": str(v)} for k, v in values.items()],
        }
        msg = {"header": header(self._clock_ns(), ""), "status": [status]}
        await self._realtime.publish(TOPICS["sim_status"].name, msg)

    async def _physics(self) -> None:
        """Step the vessel in real time at the fixed physics rate; publish the physics sensors."""
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
        now_ns = self._clock_ns()
        timeouts = self.commands.timeouts
        command, source = self.commands.current(now_ns)
        if self.commands.timeouts > timeouts:
            log.warning(
                "no command for %.1f s: zero thrust (command timeout %d)",
                self.cfg.command.timeout_s,
                self.commands.timeouts,
            )
        applied = self.commands.take_applied()
        if applied is not None and self._tracer is not None:
            topic = TOPICS["guidance_cmd"].name
            self._tracer.spans.record(
                topic, applied.stamp_ns, "actuate", applied.received_ns, now_ns
            )
        result = self.dynamics.step(self.latest_step.state, command)
        if result.collided:
            self.collisions += 1
            if not self.latest_step.collided:
                self.collision_events += 1
                log.warning("collision %d (%s driving)", self.collision_events, source)
        self.latest_step = result
        return result

    async def _publish_physics(self, result: StepResult, stamp_ns: int) -> None:
        capture = Capture(result, stamp_ns)
        for sensor in self._physics_sensors:
            msg = sensor.generate(capture).msg
            self._generated(sensor.topic, stamp_ns)
            await self._link(sensor.topic).publish(sensor.topic.name, msg)

    def _timer_tick(self, sensor: Sensor) -> Callable[[], Awaitable[None]]:
        """A tick that generates on the event loop from the latest step, stamped now."""

        async def tick() -> None:
            capture = Capture(self.latest_step, self._clock_ns())
            msg = sensor.generate(capture).msg
            self._generated(sensor.topic, capture.stamp_ns)
            await self._link(sensor.topic).publish(sensor.topic.name, msg)

        return tick

    def _worker_tick(self, sensor: Sensor) -> Callable[[], Awaitable[None]]:
        """A tick that captures pose and stamp now, generates on the sensor's thread,
        publishes the sensor's message, and any ground truth that came with it TRUTH_DELAY_S
        later."""
        loop = asyncio.get_running_loop()
        topic = sensor.topic
        executor, times = self._executors[topic.key], self.timings[topic.key]

        async def tick() -> None:
            capture = Capture(self.latest_step, self._clock_ns())
            started = time.perf_counter()
            generated: Generated = await loop.run_in_executor(executor, sensor.generate, capture)
            times.record((time.perf_counter() - started) * 1e3)
            self._generated(topic, capture.stamp_ns)
            await self._link(topic).publish(topic.name, generated.msg)
            if generated.truth:
                task = asyncio.create_task(self._publish_truth(generated.truth))
                self._truth_tasks.add(task)
                task.add_done_callback(self._truth_tasks.discard)

        return tick

    async def _publish_truth(self, truth: tuple[tuple[str, dict[str, Any]], ...]) -> None:
        await asyncio.sleep(TRUTH_DELAY_S)
        for topic, msg in truth:
            await self._client.publish(topic, msg)

    def _generated(self, topic: Topic, stamp_ns: int) -> None:
        """Trace `generate` of the thesis's sensors: capture (the stamp) -> message ready."""
        if self._tracer is not None and topic.thesis_sensor:
            self._tracer.spans.record(topic.name, stamp_ns, "generate", stamp_ns, self._clock_ns())

    async def _log_timings(self) -> None:
        log.info(
            "generation times: %s; physics lateness %s; collisions %d",
            "; ".join(f"{name} {times.summary()}" for name, times in self.timings.items()),
            self.physics_lateness.summary(),
            self.collisions,
        )


async def serve(
    url: str,
    cfg: SimConfig,
    stop: asyncio.Event,
    *,
    encoding: Encoding = "cbor",
    scene: Scene | None = None,
    connect_timeout_s: float = 10.0,
) -> None:
    """Build the scene (off the event loop), connect to the bridge at `url`, run until `stop`."""
    if scene is None:
        scene = await asyncio.to_thread(build_scene, cfg.scene, seed=cfg.seed)
    async with node_links(
        url, "simulator", encoding=encoding, connect_timeout_s=connect_timeout_s
    ) as links:
        log.info(
            "simulator connected to %s (%s, bulk and realtime connections); %d triangles",
            url,
            encoding,
            scene.triangle_count,
        )
        await SimulatorNode(
            links.bulk, cfg, scene, realtime=links.realtime, tracer=links.tracer
        ).run(stop)
