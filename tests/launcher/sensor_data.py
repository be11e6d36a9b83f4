"""What only sensor data can put into navigation's outputs, for the "works end to end" tests.

Navigation publishes ``/nav/obstacle_map`` on a timer from start-up, so a map's shape proves
nothing; these tests ask for occupied cells where an object is: an obstacle on the water that
the simulator's ground truth names, or a radar echo the test itself sent. Pure functions over
canonical messages, plus one async loop over an ordinary client.
"""

from __future__ import annotations

import asyncio
import math
import time
from typing import Any

import numpy as np

from clients import RosbridgeClient
from tests.navigation.nav_scenes import radar_image_of

OCCUPIED = 100  # nav_msgs/msg/OccupancyGrid: certainly an obstacle
# A radar detection is marked at its cell's centre: 4 m cells of 5 deg, ~4 m across at 50 m,
# so it can lie this far from the object's centre and still be that object.
NEAR_M = 5.0
MAP_TOPIC, MAP_TYPE = "/nav/obstacle_map", "nav_msgs/msg/OccupancyGrid"
TRUTH_TOPIC, TRUTH_TYPE = "/sim/ground_truth/radar", "riverbridge_msgs/msg/GroundTruthArray"
RADAR_TOPIC, RADAR_TYPE = "/radar/image", "riverbridge_msgs/msg/RadarImage"


def occupied_xy_m(grid: dict[str, Any]) -> np.ndarray:
    """(n, 2) centres of the OCCUPIED cells of an OccupancyGrid, in its frame, metres."""
    info = grid["info"]
    width, height, resolution = int(info["width"]), int(info["height"]), float(info["resolution"])
    cells = np.asarray(grid["data"], np.int16).reshape(height, width)
    rows, cols = np.nonzero(cells == OCCUPIED)
    origin = info["origin"]["position"]
    x = float(origin["x"]) + (cols + 0.5) * resolution
    y = float(origin["y"]) + (rows + 0.5) * resolution
    return np.column_stack([x, y])


def marked(grid: dict[str, Any], points_xy_m: np.ndarray, near_m: float = NEAR_M) -> np.ndarray:
    """(k,) bool: which points have an OCCUPIED cell within ``near_m``."""
    occupied = occupied_xy_m(grid)
    points = np.asarray(points_xy_m, np.float64).reshape(-1, 2)
    if not len(occupied):
        return np.zeros(len(points), bool)
    gaps = np.linalg.norm(points[:, None] - occupied[None], axis=-1)
    found: np.ndarray = gaps.min(axis=1) <= near_m
    return found


def water_obstacles_xy_m(truth: dict[str, Any]) -> np.ndarray:
    """(k, 2) centres of the on-water objects a GroundTruthArray names, in its sensor frame."""
    return np.array(
        [[o["center"]["x"], o["center"]["y"]] for o in truth["objects"] if o["on_water"]]
    ).reshape(-1, 2)


async def map_marking_a_water_obstacle(url: str, timeout_s: float = 90.0) -> dict[str, Any]:
    """The first obstacle map with an occupied cell at an obstacle on the water that the
    simulator's latest radar truth names (the radar sits over the vessel frame's origin).
    AssertionError naming what arrived when none does within ``timeout_s``."""
    latest: dict[str, Any] = {}
    async with RosbridgeClient(url, encoding="cbor") as client:
        truths = await client.subscribe(TRUTH_TOPIC, TRUTH_TYPE)
        maps = await client.subscribe(MAP_TOPIC, MAP_TYPE)

        async def keep_truth() -> None:
            async for received in truths:
                latest["truth"] = received.msg

        keeper = asyncio.create_task(keep_truth())
        try:
            async with asyncio.timeout(timeout_s):
                async for received in maps:
                    latest["map"] = grid = received.msg
                    obstacles = water_obstacles_xy_m(latest.get("truth", {"objects": []}))
                    if len(obstacles) and marked(grid, obstacles).any():
                        return grid
        except TimeoutError:
            pass
        finally:
            keeper.cancel()
    seen = {
        k: (len(occupied_xy_m(v)) if k == "map" else len(v["objects"])) for k, v in latest.items()
    }
    raise AssertionError(f"no map marked an obstacle on the water in {timeout_s:g} s: {seen}")


def radar_echo(beam: int, cell: int, stamp_ns: int) -> dict[str, Any]:
    """A riverbridge_msgs/msg/RadarImage of the default radar (72 beams x 25 cells of 4 m)
    that is empty but for one strong echo: what a buoy at (beam, cell) returns."""
    beams, cells = 72, 25
    image = np.zeros((beams, cells), np.float32)
    image[beam, cell] = 100.0
    return radar_image_of(image, stamp_ns, 4.0)


def echo_xy_m(beam: int, cell: int) -> np.ndarray:
    """(2,) where `radar_echo`'s echo lies: its cell's centre, radar frame."""
    azimuth, range_m = math.radians(5.0 * beam), 4.0 * cell + 2.0
    return np.array([range_m * math.cos(azimuth), range_m * math.sin(azimuth)])


async def map_marking_an_echo(url: str, timeout_s: float = 60.0) -> dict[str, Any]:
    """Send a radar echo (as the simulator would, every 0.5 s) until navigation's obstacle
    map marks its place: the sensor path from the bridge through navigation works."""
    beam, cell = 9, 10  # 45 deg to port, 42 m out
    where = echo_xy_m(beam, cell)
    async with RosbridgeClient(url, encoding="cbor") as client:
        await client.advertise(RADAR_TOPIC, RADAR_TYPE)
        maps = await client.subscribe(MAP_TOPIC, MAP_TYPE)

        async def send_echoes() -> None:
            while True:
                await client.publish(RADAR_TOPIC, radar_echo(beam, cell, time.time_ns()))
                await asyncio.sleep(0.5)

        sender = asyncio.create_task(send_echoes())
        try:
            async with asyncio.timeout(timeout_s):
                async for received in maps:
                    if marked(received.msg, where[None], near_m=3.0)[0]:
                        return received.msg
        except TimeoutError:
            pass
        finally:
            sender.cancel()
    raise AssertionError(f"no obstacle map marked the radar echo at {where.round(1)} m")


async def record_imu_arrivals(
    client: RosbridgeClient, arrivals: list[tuple[float, float]]
) -> asyncio.Task[None]:
    """Subscribe to the IMU; the returned task appends (received, header stamp) of each sample,
    wall-clock seconds, to `arrivals` until cancelled (how a kill's recovery is timed)."""
    sub = await client.subscribe("/imu/data", "sensor_msgs/msg/Imu")

    async def collect() -> None:
        async for received in sub:
            stamp = received.msg["header"]["stamp"]
            arrivals.append((time.time(), stamp["sec"] + stamp["nanosec"] / 1e9))

    return asyncio.create_task(collect())


def imu_flowed(arrivals: list[tuple[float, float]], since: float, settle_s: float) -> bool:
    """IMU samples have kept arriving since `since` for `settle_s` (a restart has settled),
    the latest < 0.5 s ago."""
    now = time.time()
    return now - since >= settle_s and bool(arrivals) and now - arrivals[-1][0] < 0.5
