"""Guidance's edge: navigation's output and the odometry in, `/guidance/cmd_wrench` out.

One connection to the bridge (every message guidance moves is small; the obstacle map, 160 kB,
comes twice a second). Subscriptions only keep the newest message of each input; a fixed-rate
control loop (`control.rate_hz`) turns the newest of everything into a `Situation`, asks the
pilot (guidance.pilot) and publishes its command stamped at the tick.

Perception -> actuation (docs/guidance.md): the first command that used a LIDAR boxes message
or a radar detections message records a `guide` span keyed by the *sensor's* topic and the
scan's stamp (start: navigation's output decoded here, end: the command's stamp); the simulator
records `actuate` keyed by the command's topic and stamp when it applies it. The report joins
the two into scan stamp -> command applied.

Faults are logged and counted (`GuidanceCounters`): navigation's output going stale (guidance
slows, then stops), the pose going stale (stop), a person taking over (/cmd_wrench).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clients import RosbridgeClient, Subscription
from clients.node.telemetry import telemetry
from clients.protocol import Encoding
from clients.tracing import Tracer
from guidance.config import GuidanceConfig
from guidance.messages import (
    PoseHistory,
    box_obstacles,
    grid_obstacles,
    path_msg,
    pose_of,
    radar_obstacles,
    target_msg,
    to_map,
    wrench_stamped_msg,
)
from guidance.path import Route
from guidance.pilot import Decision, Pilot, Situation, VesselPose
from schemas.catalogue import TOPICS
from schemas.runtime.event_loop import run_until_set
from schemas.runtime.process import freeze_startup_heap, tune_process
from schemas.tracing import header_stamp_ns

log = logging.getLogger(__name__)

NS_PER_S = 1_000_000_000
COMMAND = TOPICS["guidance_cmd"]
# The inputs whose first use by a command is traced, and the sensor each comes from.
CAUSES = {
    TOPICS["boxes"].name: TOPICS["lidar"].name,
    TOPICS["radar_detections"].name: TOPICS["radar"].name,
}
STATUS_PERIOD_S = 10.0


@dataclass
class Layer:
    """The newest obstacles of one input, in the map frame, with their stamp."""

    stamp_ns: int = 0
    points_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


@dataclass
class GuidanceCounters:
    """What the loop did: ticks, stale spells (navigation, pose), manual takeovers, modes."""

    ticks: int = 0
    stale_inputs: int = 0
    stale_pose: int = 0
    manual: int = 0
    modes: dict[str, int] = field(default_factory=dict)


def utm_route(cfg: GuidanceConfig) -> Route:
    """The configured waypoints in the map frame."""
    route = cfg.route
    origin = np.array([route.origin_easting_m, route.origin_northing_m])
    return Route(np.asarray(route.waypoints_utm, dtype=np.float64) - origin)


class GuidanceNode:
    """Runs the control loop against a connected client until `stop` is set."""

    def __init__(
        self,
        client: RosbridgeClient,
        cfg: GuidanceConfig,
        *,
        tracer: Tracer | None = None,
        clock_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        self._client = client
        self.cfg = cfg
        self._tracer = tracer
        self._clock_ns = clock_ns
        self.pilot = Pilot(cfg, utm_route(cfg))
        self.history = PoseHistory()
        self.pose: VesselPose | None = None
        self._pose_ns = 0
        self._layers: dict[str, Layer] = {}
        self._causes: dict[str, tuple[int, int]] = {}  # sensor topic -> (stamp, decoded)
        self._manual_ns = 0
        self.counters = GuidanceCounters()
        self.mode = "stop"
        self._stale = {"inputs": False, "pose": False}
        self._mode_tasks: set[asyncio.Task[None]] = set()

    async def run(self, stop: asyncio.Event) -> None:
        client = self._client
        await client.advertise(*COMMAND.pair)
        await client.advertise(*TOPICS["guidance_path"].pair, latch=True)
        await client.advertise(*TOPICS["guidance_target"].pair)
        await client.advertise(*TOPICS["guidance_mode"].pair)
        await client.publish(
            TOPICS["guidance_path"].name, path_msg(self.pilot.route.points_m, self._clock_ns())
        )
        handlers = {
            "odom": self._on_odom,
            "cmd_wrench": self._on_operator,
            "obstacle_map": self._on_output,
            "boxes": self._on_output,
            "radar_detections": self._on_output,
        }
        readers = []
        for key, handle in handlers.items():
            subscription = await client.subscribe(*TOPICS[key].pair, maxsize=1)
            readers.append(self._read(subscription, handle))
        tasks = [asyncio.create_task(r) for r in readers]
        tasks.append(asyncio.create_task(self._control_loop()))
        tasks.append(asyncio.create_task(self._status_loop()))
        await run_until_set(stop, tasks)

    async def _read(self, subscription: Subscription, handle: Callable[[str, Any], None]) -> None:
        async for received in subscription:
            try:
                handle(received.topic, received.msg)
            except (KeyError, TypeError, ValueError) as exc:
                log.warning("ignoring a malformed %s message: %s", received.topic, exc)

    def _on_odom(self, _topic: str, msg: Any) -> None:
        stamp_ns = header_stamp_ns(msg) or self._clock_ns()
        self.pose = pose_of(msg)
        self._pose_ns = stamp_ns
        self.history.add(stamp_ns, self.pose)

    def _on_operator(self, _topic: str, _msg: Any) -> None:
        if not self._manual_now():
            self.counters.manual += 1
            log.info("a person commands /cmd_wrench: guidance stands by")
        self._manual_ns = self._clock_ns()

    def _on_output(self, topic: str, msg: Any) -> None:
        stamp_ns = header_stamp_ns(msg)
        if stamp_ns is None:
            raise ValueError("no header.stamp")
        pose = self.history.at(stamp_ns)
        if pose is None:
            return
        avoid = self.cfg.avoidance
        if topic == TOPICS["obstacle_map"].name:
            local = grid_obstacles(msg)
        elif topic == TOPICS["boxes"].name:
            local = box_obstacles(msg, avoid.lidar_offset_xy_m, avoid.max_obstacle_z_m)
        else:
            local = radar_obstacles(msg, avoid.radar_offset_xy_m)
        self._layers[topic] = Layer(stamp_ns, to_map(local, pose))
        if topic in CAUSES:
            decoded_ns = self._clock_ns()
            if self._tracer is not None:
                decoded_ns = self._tracer.decoded_ns(topic, stamp_ns, decoded_ns)
            self._causes[CAUSES[topic]] = (stamp_ns, decoded_ns)

    def _manual_now(self) -> bool:
        override_ns = self.cfg.inputs.operator_override_s * NS_PER_S
        return self._manual_ns > 0 and self._clock_ns() - self._manual_ns < override_ns

    def situation(self, dt_s: float) -> Situation:
        """What the pilot knows now; layers older than `stop_age_s` are forgotten."""
        now_ns = self._clock_ns()
        stop_ns = self.cfg.inputs.stop_age_s * NS_PER_S
        fresh = [layer for layer in self._layers.values() if now_ns - layer.stamp_ns < stop_ns]
        newest = max((layer.stamp_ns for layer in self._layers.values()), default=None)
        obstacles = np.concatenate([np.zeros((0, 2)), *(layer.points_m for layer in fresh)])
        return Situation(
            pose=self.pose,
            pose_age_s=None if self.pose is None else (now_ns - self._pose_ns) / NS_PER_S,
            obstacles_m=obstacles,
            input_age_s=None if newest is None else (now_ns - newest) / NS_PER_S,
            manual=self._manual_now(),
            dt_s=dt_s,
        )

    async def _control_loop(self) -> None:
        """Tick at `control.rate_hz` on a fixed schedule (a late tick does not shift the next)."""
        loop = asyncio.get_running_loop()
        period_s = 1.0 / self.cfg.control.rate_hz
        next_s = loop.time()
        while True:
            try:
                await self._tick(period_s)
            except Exception:  # one failed tick must not end the loop
                log.exception("guidance tick failed")
            next_s += period_s
            next_s = max(next_s, loop.time() - period_s)  # after a stall: no burst of ticks
            await asyncio.sleep(max(0.0, next_s - loop.time()))

    async def _tick(self, dt_s: float) -> None:
        now = self.situation(dt_s)
        decision = self.pilot.decide(now)
        self._note(now, decision)
        stamp_ns = self._clock_ns()
        if decision.wrench is not None:
            await self._client.publish(COMMAND.name, wrench_stamped_msg(decision.wrench, stamp_ns))
            self._trace_causes(stamp_ns)
        await self._client.publish(
            TOPICS["guidance_target"].name, target_msg(decision.target_m, stamp_ns)
        )

    def _trace_causes(self, command_ns: int) -> None:
        """`guide` spans: each new input's first command (docs/guidance.md)."""
        if self._tracer is not None:
            for sensor, (stamp_ns, decoded_ns) in self._causes.items():
                self._tracer.spans.record(sensor, stamp_ns, "guide", decoded_ns, command_ns)
        self._causes.clear()

    def _note(self, now: Situation, decision: Decision) -> None:
        """Count and log the faults' edges (not every tick of them) and mode changes."""
        counters = self.counters
        counters.ticks += 1
        counters.modes[decision.mode] = counters.modes.get(decision.mode, 0) + 1
        inputs = self.cfg.inputs
        stale_inputs = now.input_age_s is None or now.input_age_s > inputs.slow_age_s
        stale_pose = now.pose_age_s is None or now.pose_age_s > inputs.pose_max_age_s
        for name, stale in (("inputs", stale_inputs), ("pose", stale_pose)):
            if stale and not self._stale[name]:
                setattr(counters, f"stale_{name}", getattr(counters, f"stale_{name}") + 1)
                age = now.input_age_s if name == "inputs" else now.pose_age_s
                known = "never received" if age is None else f"{age:.2f} s old"
                if name == "inputs":
                    log.warning(
                        "navigation output is stale (%s): slowing, stopped at %.1f s",
                        known, inputs.stop_age_s,
                    )  # fmt: skip
                else:
                    log.warning("odometry is stale (%s): stopping", known)
            elif not stale and self._stale[name]:
                log.info("%s fresh again", "navigation output" if name == "inputs" else "odometry")
            self._stale[name] = stale
        if decision.mode != self.mode:
            log.info(
                "mode %s -> %s: %.0f m along the route, %.1f m off it, steering %.0f deg "
                "(free %.0f m) at %.1f m/s",
                self.mode, decision.mode, decision.along_m, decision.cross_track_m,
                np.degrees(decision.heading_rad), decision.free_m, decision.speed_mps,
            )  # fmt: skip
            self.mode = decision.mode
            task = asyncio.get_running_loop().create_task(self._publish_mode())
            self._mode_tasks.add(task)  # held until done (the loop keeps only weak references)
            task.add_done_callback(self._mode_tasks.discard)

    async def _publish_mode(self) -> None:
        await self._client.publish(TOPICS["guidance_mode"].name, {"data": self.mode})

    async def _status_loop(self) -> None:
        """The mode once a second (and on every change); the counters in the log."""
        last_log_s = 0.0
        loop = asyncio.get_running_loop()
        while True:
            await self._publish_mode()
            if loop.time() - last_log_s >= STATUS_PERIOD_S:
                last_log_s = loop.time()
                c = self.counters
                log.info(
                    "ticks %d, modes %s, stale navigation %d, stale odometry %d, manual %d",
                    c.ticks, c.modes, c.stale_inputs, c.stale_pose, c.manual,
                )  # fmt: skip
            await asyncio.sleep(1.0)


async def serve(
    url: str,
    cfg: GuidanceConfig,
    stop: asyncio.Event,
    *,
    encoding: Encoding = "cbor",
    connect_timeout_s: float = 10.0,
) -> None:
    """Connect to the bridge at `url` and run the loop until `stop`."""
    tune_process()
    tracer = Tracer("guidance")
    async with RosbridgeClient(
        url, encoding=encoding, name="guidance", connect_timeout=connect_timeout_s, tracer=tracer
    ) as client:
        freeze_startup_heap()
        async with telemetry(client, tracer):
            log.info("guidance connected to %s (%s); route %.0f m", url, encoding,
                     utm_route(cfg).length_m)  # fmt: skip
            await GuidanceNode(client, cfg, tracer=tracer).run(stop)
