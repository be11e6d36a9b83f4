// The dashboard: one rosbridge connection (CBOR, throttled per topic), a worker with a connection
// of its own for the LIDAR scans, six panels, one requestAnimationFrame loop that redraws only
// what changed. `window.riverbridgeDashboard` exposes counters for the browser tests and the
// frame-time benchmark.
import "./style.css";
import { Connection, bridgeUrl } from "./connection.js";
import { KeyboardSteering } from "./keyboard.js";
import { startLidarWorker } from "./lidar/feed.js";
import { CameraPanel } from "./panels/camera.js";
import { ImuPanel } from "./panels/imu.js";
import { LatencyPanel } from "./panels/latency.js";
import { MapPanel } from "./panels/map.js";
import { RadarPanel } from "./panels/radar.js";
import { TopicsPanel } from "./panels/topics.js";
import { RateMeter } from "./rolling.js";
import { stampMs, yawOf } from "./rosmsg.js";
import { ArrivalAges, TraceStats } from "./trace.js";

// Per topic: type, and the fastest the bridge may send it to this page (throttle_rate, ms).
// queue_length 1 makes the bridge drop stale messages for a slow page instead of queueing.
// /lidar/points is not here: its 2.9 MB scans are decoded and decimated in a worker (LIDAR).
const SUBSCRIPTIONS = {
  "/radar/image": ["riverbridge_msgs/msg/RadarImage", 250],
  "/camera/image/compressed": ["sensor_msgs/msg/CompressedImage", 100],
  "/imu/data": ["sensor_msgs/msg/Imu", 10],
  "/odom": ["nav_msgs/msg/Odometry", 50],
  "/tf_static": ["tf2_msgs/msg/TFMessage", 0],
  "/nav/boxes": ["riverbridge_msgs/msg/BoxArray", 100],
  "/nav/radar_detections": ["riverbridge_msgs/msg/RadarDetectionArray", 100],
  "/nav/lines": ["riverbridge_msgs/msg/ImageLineArray", 100],
  "/nav/obstacle_map": ["nav_msgs/msg/OccupancyGrid", 250],
  "/riverbridge/trace": ["riverbridge_msgs/msg/TraceSpanArray", 0],
  "/riverbridge/process_stats": ["riverbridge_msgs/msg/ProcessStats", 0],
  "/riverbridge/restarts": ["diagnostic_msgs/msg/DiagnosticArray", 0], // latched, from `up`
};
const LIDAR = { topic: "/lidar/points", messageType: "sensor_msgs/msg/PointCloud2",
  throttleMs: 250, maxPoints: 40000 }; // 40k of a ~180k scan: more adds no visible detail
const ALL_TOPICS = [...Object.keys(SUBSCRIPTIONS), LIDAR.topic];
// Topics whose header.stamp is a capture time: their age on arrival is shown as latency.
const AGED_TOPICS = new Set(["/radar/image", "/camera/image/compressed", "/imu/data", "/odom",
  "/nav/boxes", "/nav/radar_detections", "/nav/lines", "/nav/obstacle_map"]);

function startDashboard() {
  const url = bridgeUrl(window.location);
  const status = document.getElementById("connection");
  document.getElementById("bridge-url").textContent = url;
  const connection = new Connection(url, (connected) => {
    status.textContent = connected ? "connected" : "disconnected";
    status.className = `badge ${connected ? "badge-on" : "badge-off"}`;
  });
  const trace = new TraceStats();
  const ages = new ArrivalAges();
  const rates = new Map(ALL_TOPICS.map((topic) => [topic, new RateMeter()]));
  const counts = Object.fromEntries(ALL_TOPICS.map((topic) => [topic, 0]));
  const handlerWorstMs = {}; // topic -> longest time one message took to handle, ms
  const panels = {
    map: new MapPanel(document.getElementById("map")),
    camera: new CameraPanel(document.getElementById("camera")),
    radar: new RadarPanel(document.getElementById("radar")),
    imu: new ImuPanel(document.getElementById("imu")),
    latency: new LatencyPanel(document.getElementById("latency"), trace, ages),
    topics: new TopicsPanel(document.getElementById("topics"), connection, rates),
  };
  const vessel = { yawRad: NaN, speedMps: NaN, stampMs: NaN };
  const handlers = messageHandlers(panels, trace, vessel);
  const received = (topic, handle) => {
    const now = performance.now();
    counts[topic] += 1;
    rates.get(topic).tick(now);
    handle(now);
    handlerWorstMs[topic] = Math.max(handlerWorstMs[topic] ?? 0, performance.now() - now);
  };
  for (const [topic, [type, throttleMs]] of Object.entries(SUBSCRIPTIONS)) {
    const options = { compression: "cbor", throttle_rate: throttleMs, queue_length: 1 };
    connection.subscribe(topic, type, options, (message) => received(topic, (now) => {
      if (AGED_TOPICS.has(topic)) ages.record(topic, Date.now() - stampMs(message.header));
      handlers[topic](message, now);
    }));
  }
  const lidar = startLidarWorker({ url, ...LIDAR }, (cloud) => {
    if (cloud.replot) {
      if (cloud.bitmap) panels.map.onPointsImage(cloud.bitmap, cloud.pointCount);
      return;
    }
    received(LIDAR.topic, () => {
      ages.record(LIDAR.topic, cloud.ageMs); // capture -> decoded in the worker
      const inWorker = `${LIDAR.topic} (worker: decimate + plot)`; // off the main thread
      handlerWorstMs[inWorker] = Math.max(handlerWorstMs[inWorker] ?? 0, cloud.workMs);
      if (cloud.bitmap) panels.map.onPointsImage(cloud.bitmap, cloud.pointCount);
    });
  });
  panels.map.onView = lidar.setView;
  const steering = new KeyboardSteering(window, connection, showCommand);
  const frames = runFrames(panels, vessel);
  connection.start();
  window.riverbridgeDashboard = { counts, vessel, trace, ages, frames, steering, connection, lidar,
    panels, handlerWorstMs };
}

/** Topic -> fn(message, receivedMs) for the topics of the page's own connection. */
function messageHandlers(panels, trace, vessel) {
  return {
    "/radar/image": (m) => panels.radar.onImage(m),
    "/camera/image/compressed": (m) => panels.camera.onImage(m),
    "/imu/data": (m, now) => panels.imu.onImu(m, now),
    "/odom": (m) => Object.assign(vessel, odometryReadout(m)),
    "/tf_static": (m) => panels.map.onStaticTf(m),
    "/nav/boxes": (m) => panels.map.onBoxes(m),
    "/nav/radar_detections": (m) => {
      panels.map.onDetections(m);
      panels.radar.onDetections(m);
    },
    "/nav/lines": (m) => panels.camera.onLines(m),
    "/nav/obstacle_map": (m) => panels.map.onGrid(m),
    "/riverbridge/trace": (m) => trace.onSpans(m),
    "/riverbridge/process_stats": (m) => panels.topics.onProcessStats(m),
    "/riverbridge/restarts": (m) => panels.topics.onRestarts(m),
  };
}

function showCommand(surge, yaw, active) {
  const readout = document.getElementById("command");
  readout.textContent = active
    ? `⌨ surge ${surge.toFixed(0)} N · yaw ${yaw.toFixed(0)} N·m`
    : "⌨ ←↑→↓ steer · space stop";
  readout.classList.toggle("active", active);
}

function odometryReadout(odometry) {
  const v = odometry.twist.twist.linear;
  return {
    yawRad: yawOf(odometry.pose.pose.orientation),
    speedMps: Math.hypot(v.x, v.y),
    stampMs: stampMs(odometry.header),
  };
}

/** The rAF loop; returns counters of its draw work (ms), overall and per panel. */
function runFrames(panels, vessel) {
  const frames = { count: 0, lastWorkMs: 0, worstWorkMs: 0, panelWorstMs: {} };
  const readout = document.getElementById("vessel");
  let shownYaw = null;
  const frame = (nowMs) => {
    const start = performance.now();
    for (const [name, panel] of Object.entries(panels)) {
      const before = performance.now();
      panel.draw(nowMs);
      const spent = performance.now() - before;
      frames.panelWorstMs[name] = Math.max(frames.panelWorstMs[name] ?? 0, spent);
    }
    if (vessel.yawRad !== shownYaw && Number.isFinite(vessel.yawRad)) {
      shownYaw = vessel.yawRad;
      const headingDeg = ((90 - (vessel.yawRad * 180) / Math.PI) % 360 + 360) % 360;
      readout.textContent = `heading ${headingDeg.toFixed(1)}° · speed ${vessel.speedMps.toFixed(2)} m/s`;
    }
    const work = performance.now() - start;
    frames.count += 1;
    frames.lastWorkMs = work;
    frames.worstWorkMs = Math.max(frames.worstWorkMs, work);
    requestAnimationFrame(frame);
  };
  requestAnimationFrame(frame);
  return frames;
}

startDashboard();
