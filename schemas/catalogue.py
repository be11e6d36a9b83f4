"""Every topic the simulator, navigation and the telemetry publish or read, in one table.

Plain data, no I/O. (The bridge's own ``/rosout`` and ``/client_count`` are not here.)

The simulator advertises and schedules its sensors from it, navigation subscribes and
advertises from it, ``riverbridge up`` waits for its publishers, the report takes its topic
lists from it and the dashboard its topic list (``web/src/catalogue.json``, written by
``python3 scripts/catalogue_json.py``; a test keeps the two equal). A new topic is one entry
here; its producer then finds it by key.

Rates are not numbers here but where the number lives: ``rate_key``, the producer's
configuration key holding the rate in Hz (simulator: ``SimConfig``, navigation:
``NavigationConfig``); ``follows``, the topic whose every message yields one; ``period_s``,
a fixed period where no configuration sets it; ``latched``, sent once and kept for late
subscribers. A command has none of these: it comes when an operator sends it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from types import MappingProxyType
from typing import Any, Literal

# Who publishes: one of the stack's processes, every process (telemetry; the bridge too),
# `riverbridge up` (the supervisor), or an operator (the dashboard's keyboard, `riverbridge
# teleop`, any rosbridge client).
Producer = Literal["simulator", "navigation", "guidance", "every process", "supervisor", "operator"]
# What it carries, and so how its producer treats it:
#   sensor    heavy sensor data: a worker thread of its own, the producer's bulk connection
#   realtime  small, frequent messages: the producer's realtime connection, never behind a scan
#   static    the set-up, latched: sensor mounts, the effective configuration
#   truth     what the simulator knows, for judging navigation (docs/quality.md)
#   command   an operator's demand
#   output    navigation's and guidance's results
#   telemetry how the stack is doing: diagnostics, trace spans, process statistics, restarts
Role = Literal["sensor", "realtime", "static", "truth", "command", "output", "telemetry"]
ROLES: tuple[Role, ...] = (
    "sensor",
    "realtime",
    "static",
    "truth",
    "command",
    "output",
    "telemetry",
)
PRODUCERS: tuple[Producer, ...] = (
    "simulator",
    "navigation",
    "guidance",
    "every process",
    "supervisor",
    "operator",
)


@dataclass(frozen=True)
class Topic:
    """One topic. ``key`` is the short name code and configuration use (``"lidar"``).

    consumers : the stack's processes (and the dashboard) that subscribe to it.
    thesis_sensor : one of the thesis's four sensor streams (table 4.9): the report sums their
        payload and sets their latency beside the thesis's; the simulator traces their
        generation.
    enabled_by : the producer's boolean configuration key that turns it on ("" = always on).
    """

    key: str
    name: str
    type: str
    producer: Producer
    role: Role
    summary: str
    rate_key: str = ""
    follows: str = ""
    period_s: float | None = None
    latched: bool = False
    consumers: tuple[str, ...] = ()
    thesis_sensor: bool = False
    enabled_by: str = ""

    @property
    def pair(self) -> tuple[str, str]:
        """(name, type), as ``advertise`` and ``subscribe`` take them."""
        return self.name, self.type


_PHYSICS = "vessel.physics_rate_hz"  # published once per physics step
_TRUTH = "ground_truth.enabled"

_ENTRIES = (
    # The simulator's sensors (thesis 3.5.2; tables 4.1, 4.3, 4.5) and the vessel's state.
    Topic(
        "lidar",
        "/lidar/points",
        "sensor_msgs/msg/PointCloud2",
        "simulator",
        "sensor",
        "LIDAR scan, sensor frame",
        rate_key="lidar.rate_hz",
        consumers=("navigation", "dashboard"),
        thesis_sensor=True,
    ),
    Topic(
        "radar",
        "/radar/image",
        "riverbridge_msgs/msg/RadarImage",
        "simulator",
        "sensor",
        "radar polar image, one sweep",
        rate_key="radar.rate_hz",
        consumers=("navigation", "dashboard"),
        thesis_sensor=True,
    ),
    Topic(
        "camera",
        "/camera/image/compressed",
        "sensor_msgs/msg/CompressedImage",
        "simulator",
        "sensor",
        "camera frame, JPEG",
        rate_key="camera.rate_hz",
        consumers=("navigation", "dashboard"),
        thesis_sensor=True,
    ),
    Topic(
        "imu",
        "/imu/data",
        "sensor_msgs/msg/Imu",
        "simulator",
        "realtime",
        "IMU sample",
        rate_key=_PHYSICS,
        consumers=("navigation", "dashboard"),
        thesis_sensor=True,
    ),
    Topic(
        "gnss",
        "/gnss/fix",
        "sensor_msgs/msg/NavSatFix",
        "simulator",
        "realtime",
        "GNSS fix",
        rate_key="gnss.rate_hz",
    ),
    Topic(
        "odom",
        "/odom",
        "nav_msgs/msg/Odometry",
        "simulator",
        "realtime",
        "the vessel's true pose and velocity",
        rate_key=_PHYSICS,
        consumers=("dashboard", "guidance"),
    ),
    Topic(
        "tf",
        "/tf",
        "tf2_msgs/msg/TFMessage",
        "simulator",
        "realtime",
        "map -> base_link",
        rate_key=_PHYSICS,
    ),
    Topic(
        "tf_static",
        "/tf_static",
        "tf2_msgs/msg/TFMessage",
        "simulator",
        "static",
        "base_link -> every sensor frame",
        latched=True,
        consumers=("dashboard",),
    ),
    Topic(
        "sim_config",
        "/sim/config",
        "std_msgs/msg/String",
        "simulator",
        "static",
        "the simulator's effective configuration as JSON",
        latched=True,
    ),
    Topic(
        "ground_truth",
        "/sim/ground_truth",
        "visualization_msgs/msg/MarkerArray",
        "simulator",
        "truth",
        "the scene's objects as boxes, map frame",
        latched=True,
        enabled_by=_TRUTH,
    ),
    Topic(
        "lidar_truth",
        "/sim/ground_truth/lidar",
        "riverbridge_msgs/msg/GroundTruthArray",
        "simulator",
        "truth",
        "the objects a LIDAR scan saw",
        follows="/lidar/points",
        enabled_by=_TRUTH,
    ),
    Topic(
        "radar_truth",
        "/sim/ground_truth/radar",
        "riverbridge_msgs/msg/GroundTruthArray",
        "simulator",
        "truth",
        "the objects a radar sweep saw, per cell",
        follows="/radar/image",
        enabled_by=_TRUTH,
    ),
    Topic(
        "cmd_wrench",
        "/cmd_wrench",
        "geometry_msgs/msg/Wrench",
        "operator",
        "command",
        "surge force and yaw moment; overrides the autopilot for a few seconds",
        consumers=("simulator", "guidance"),
    ),
    Topic(
        "sim_status",
        "/sim/status",
        "diagnostic_msgs/msg/DiagnosticArray",
        "simulator",
        "telemetry",
        "who commands the vessel, command timeouts, collisions",
        period_s=1.0,
    ),
    # Navigation's results (thesis 3.5.3) and its health.
    Topic(
        "boxes",
        "/nav/boxes",
        "riverbridge_msgs/msg/BoxArray",
        "navigation",
        "output",
        "LIDAR obstacle boxes",
        follows="/lidar/points",
        consumers=("dashboard", "guidance"),
    ),
    Topic(
        "markers",
        "/nav/markers",
        "visualization_msgs/msg/MarkerArray",
        "navigation",
        "output",
        "LIDAR obstacle boxes for RViz and Foxglove",
        follows="/lidar/points",
    ),
    Topic(
        "radar_detections",
        "/nav/radar_detections",
        "riverbridge_msgs/msg/RadarDetectionArray",
        "navigation",
        "output",
        "CFAR detections and targets",
        follows="/radar/image",
        consumers=("dashboard", "guidance"),
    ),
    Topic(
        "lines",
        "/nav/lines",
        "riverbridge_msgs/msg/ImageLineArray",
        "navigation",
        "output",
        "Hough lines of a camera frame",
        follows="/camera/image/compressed",
        consumers=("dashboard",),
    ),
    Topic(
        "obstacle_map",
        "/nav/obstacle_map",
        "nav_msgs/msg/OccupancyGrid",
        "navigation",
        "output",
        "LIDAR and radar obstacles fused",
        rate_key="fusion.publish_rate_hz",
        consumers=("dashboard", "guidance"),
    ),
    Topic(
        "diagnostics",
        "/nav/diagnostics",
        "diagnostic_msgs/msg/DiagnosticArray",
        "navigation",
        "telemetry",
        "per-sensor rates, gaps, skips and failures",
        period_s=1.0,
    ),
    # Guidance and control (docs/guidance.md): the autopilot's command, route and state.
    Topic(
        "guidance_cmd",
        "/guidance/cmd_wrench",
        "geometry_msgs/msg/WrenchStamped",
        "guidance",
        "command",
        "the autopilot's surge force and yaw moment, stamped at its control tick",
        consumers=("simulator",),
    ),
    Topic(
        "guidance_path",
        "/guidance/path",
        "nav_msgs/msg/Path",
        "guidance",
        "output",
        "the route followed, map frame",
        latched=True,
        consumers=("dashboard",),
    ),
    Topic(
        "guidance_target",
        "/guidance/target",
        "geometry_msgs/msg/PointStamped",
        "guidance",
        "output",
        "the point on the route the vessel steers for",
        rate_key="control.rate_hz",
    ),
    Topic(
        "guidance_mode",
        "/guidance/mode",
        "std_msgs/msg/String",
        "guidance",
        "output",
        "follow, avoid, blocked, stale, stop or manual",
        period_s=1.0,
        consumers=("dashboard",),
    ),
    # Every process's telemetry (docs/tracing.md).
    Topic(
        "trace",
        "/riverbridge/trace",
        "riverbridge_msgs/msg/TraceSpanArray",
        "every process",
        "telemetry",
        "stage spans of traced messages",
        # four batches a second: building and encoding a second's worth of spans at once
        # (450 nested messages in the simulator) held an event loop for 3-5 ms on a busy
        # core, long enough to delay the IMU sample that came meanwhile
        period_s=0.25,
        consumers=("dashboard",),
    ),
    Topic(
        "process_stats",
        "/riverbridge/process_stats",
        "riverbridge_msgs/msg/ProcessStats",
        "every process",
        "telemetry",
        "CPU, memory, messages and drops of one process",
        period_s=1.0,
        consumers=("dashboard",),
    ),
    Topic(
        "restarts",
        "/riverbridge/restarts",
        "diagnostic_msgs/msg/DiagnosticArray",
        "supervisor",
        "telemetry",
        "how often `up` restarted each component",
        latched=True,
        consumers=("dashboard",),
    ),
)

TOPICS: Mapping[str, Topic] = MappingProxyType({t.key: t for t in _ENTRIES})
"""Every topic by key, in catalogue order."""


def by_name(name: str) -> Topic | None:
    """The topic called ``name``, or None when the catalogue has none."""
    return next((t for t in _ENTRIES if t.name == name), None)


def published_by(producer: Producer, *roles: Role) -> tuple[Topic, ...]:
    """What ``producer`` publishes, in catalogue order; only ``roles`` when given."""
    return tuple(t for t in _ENTRIES if t.producer == producer and (not roles or t.role in roles))


def consumed_by(consumer: str, *roles: Role) -> tuple[Topic, ...]:
    """What ``consumer`` subscribes to, in catalogue order; only ``roles`` when given."""
    return tuple(t for t in _ENTRIES if consumer in t.consumers and (not roles or t.role in roles))


def streams_of(producer: Producer) -> tuple[str, ...]:
    """Names of what ``producer`` always publishes as a stream (not latched, not switched
    off by configuration): ``up`` and the health checks wait for their publishers."""
    return tuple(t.name for t in published_by(producer) if not t.latched and not t.enabled_by)


def period_s(key: str) -> float:
    """The fixed period of topic ``key``; KeyError naming the topic if it has none."""
    value = TOPICS[key].period_s
    if value is None:
        raise KeyError(f"{TOPICS[key].name} has no fixed period")
    return value


def as_data() -> dict[str, Any]:
    """The catalogue as JSON-ready data: ``{"topics": [{field: value, ...}, ...]}``."""
    return {"topics": [{**asdict(t), "consumers": list(t.consumers)} for t in _ENTRIES]}
