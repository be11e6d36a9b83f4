"""The navigation service's edge: rosbridge in, processing on worker threads, rosbridge out.

Each heavy sensor (LIDAR, radar, camera) has its own subscription queue of one message and
its own single worker thread, so a slow LIDAR step never delays the camera or the IMU (the
IMU is cheap and handled on the event loop). The LIDAR thread hands the scan on to a worker
process (``[lidar] worker``): scikit-learn holds the GIL, which a thread would take from the
event loop that reads the IMU. A sensor that falls behind processes the newest
message; the older ones are dropped by the queue and counted as skipped. The fused obstacle
map and the diagnostics are published on timers.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

from clients import RosbridgeClient, Subscription
from clients.node.links import node_links
from clients.protocol import Encoding
from clients.tracing import Tracer
from navigation.config import NavigationConfig
from navigation.diagnostics import SensorCounters, diagnostic_array_msg
from navigation.imu import ImuTracker
from navigation.processors import (
    OUTPUT_TYPES,
    TOPIC_DIAGNOSTICS,
    Handled,
    Processors,
)
from schemas.catalogue import TOPICS, consumed_by, period_s
from schemas.runtime.event_loop import run_until_set
from schemas.runtime.periodic import every
from schemas.runtime.process import background_priority
from schemas.tracing import header_stamp_ns

log = logging.getLogger(__name__)


# What navigation reads (schemas.catalogue): the heavy sensors, each on a thread of its own,
# and the IMU on the event loop.
SENSOR_INPUTS = {t.key: t.pair for t in consumed_by("navigation", "sensor")}
IMU_INPUT = TOPICS["imu"].pair
IMU_QUEUE = 1000  # IMU messages are tiny and every one counts for the gap statistics
DIAGNOSTICS_PERIOD_S = period_s("diagnostics")


class NavigationNode:
    """Runs the processors against connected clients until ``stop`` is set.

    ``client`` carries the sensor data and every output; ``realtime`` (default: ``client``)
    the IMU, which on its own connection never queues on the wire behind a 4 MB scan.
    """

    def __init__(
        self,
        client: RosbridgeClient,
        config: NavigationConfig,
        processors: Processors | None = None,
        tracer: Tracer | None = None,
        realtime: RosbridgeClient | None = None,
    ) -> None:
        self._client = client
        self._realtime = realtime or client
        self._tracer = tracer
        self._config = config
        self.processors = processors or Processors(config)
        self.imu = ImuTracker(config.imu)
        self.counters = {name: SensorCounters() for name in SENSOR_INPUTS}
        self.subscriptions: dict[str, Subscription] = {}
        self._executors = {
            name: ThreadPoolExecutor(
                1, thread_name_prefix=f"nav-{name}", initializer=background_priority
            )
            for name in SENSOR_INPUTS
        }
        self._handlers: dict[str, Callable[[dict[str, Any]], Handled]] = self.processors.handlers()
        unhandled = SENSOR_INPUTS.keys() - self._handlers.keys()
        if unhandled:
            raise ValueError(f"no navigation handler for input topics {sorted(unhandled)}")

    async def run(self, stop: asyncio.Event) -> None:
        """Advertise, subscribe, process until ``stop`` is set, then release the threads and
        the LIDAR worker. The worker warms up on the LIDAR thread meanwhile (seconds: imports),
        so the first scan waits for it there, without holding up the other sensors."""
        self._executors["lidar"].submit(self._start_lidar_worker)
        try:
            await self._serve(stop)
        finally:
            for executor in self._executors.values():
                executor.shutdown(wait=True, cancel_futures=True)
            await asyncio.to_thread(self.processors.close)

    def _start_lidar_worker(self) -> None:
        try:
            self.processors.start()
        except Exception:  # the next scan tries again; until then LIDAR counts failures
            log.exception("lidar: the worker did not start")

    async def _serve(self, stop: asyncio.Event) -> None:
        for topic, type_name in OUTPUT_TYPES.items():
            await self._client.advertise(topic, type_name, latest_only=True)
        for name, (topic, type_name) in SENSOR_INPUTS.items():
            self.subscriptions[name] = await self._client.subscribe(topic, type_name, maxsize=1)
        imu_topic, imu_type = IMU_INPUT
        self.subscriptions["imu"] = await self._realtime.subscribe(
            imu_topic, imu_type, maxsize=IMU_QUEUE
        )
        map_period_s = 1.0 / self._config.fusion.publish_rate_hz
        tasks = [asyncio.create_task(self._sensor_loop(name)) for name in SENSOR_INPUTS]
        tasks += [
            asyncio.create_task(self._imu_loop()),
            asyncio.create_task(every(map_period_s, self._publish_map, phase=1.0)),
            asyncio.create_task(every(DIAGNOSTICS_PERIOD_S, self._publish_diagnostics, phase=1.0)),
        ]
        await run_until_set(stop, tasks)

    async def _sensor_loop(self, name: str) -> None:
        """Take the newest message, process it on the sensor's thread, publish the outputs."""
        sub, counters = self.subscriptions[name], self.counters[name]
        loop = asyncio.get_running_loop()
        async for received in sub:
            counters.skipped = sub.dropped
            start = time.perf_counter()
            start_ns = time.time_ns()
            try:
                handled = await loop.run_in_executor(
                    self._executors[name], self._handlers[name], received.msg
                )
            except Exception:  # one bad message must not end the sensor's loop
                counters.failed += 1
                log.exception("%s: processing a message from %s failed", name, sub.topic)
                continue
            counters.record((time.perf_counter() - start) * 1e3)
            if self._tracer is not None:
                self._tracer.processed(
                    sub.topic,
                    header_stamp_ns(received.msg),
                    start_ns,
                    time.time_ns(),
                    received.recv_ns,
                    handled.steps,
                )
            for topic, msg in handled.outputs:
                await self._client.publish(topic, msg)

    async def _imu_loop(self) -> None:
        async for received in self.subscriptions["imu"]:
            start_ns = time.time_ns()
            try:
                self.imu.update(received.msg, received.recv_ns)
            except (KeyError, TypeError, ValueError):
                log.exception("imu: malformed message")
                continue
            if self._tracer is not None:
                self._tracer.processed(
                    received.topic,
                    header_stamp_ns(received.msg),
                    start_ns,
                    time.time_ns(),
                    received.recv_ns,
                )

    async def _publish_map(self) -> None:
        for topic, msg in self.processors.obstacle_map():
            await self._client.publish(topic, msg)

    async def _publish_diagnostics(self) -> None:
        for name, counters in self.counters.items():
            counters.skipped = self.subscriptions[name].dropped
        msg = diagnostic_array_msg(time.time_ns(), self.imu.snapshot(), self.counters)
        await self._client.publish(TOPIC_DIAGNOSTICS, msg)


async def serve(
    url: str,
    config: NavigationConfig,
    stop: asyncio.Event,
    *,
    encoding: Encoding = "cbor",
    connect_timeout_s: float = 10.0,
) -> None:
    """Connect to the bridge at ``url`` and run the navigation node until ``stop``."""
    async with node_links(
        url, "navigation", encoding=encoding, connect_timeout_s=connect_timeout_s
    ) as links:
        log.info("navigation connected to %s (%s, bulk and realtime connections)", url, encoding)
        await NavigationNode(links.bulk, config, tracer=links.tracer, realtime=links.realtime).run(
            stop
        )
