// The dashboard: one rosbridge connection (CBOR, throttled per topic), five panels, one
// requestAnimationFrame loop that redraws only what changed. `window.riverbridgeDashboard`
// exposes counters for the browser tests and the frame-time benchmark.
import "./style.css";
import { Connection, bridgeUrl } from "./connection.js";
import { KeyboardSteering } from "./keyboard.js";
import { CameraPanel } from "./panels/camera.js";
import { ImuPanel } from "./panels/imu.js";
import { LatencyPanel } from "./panels/latency.js";
import { MapPanel } from "./panels/map.js";
import { TopicsPanel } from "./panels/topics.js";
import { RateMeter } from "./rolling.js";
import { stampMs, yawOf } from "./rosmsg.js";
import { ArrivalAges, TraceStats } from "./trace.js";

// Per topic: type, and the fastest the bridge may send it to this page (throttle_rate, ms).
// queue_length 1 makes the bridge drop stale messages for a slow page instead of queueing.
const SUBSCRIPTIONS = {
  "/lidar/points": ["sensor_msgs/msg/PointCloud2", 250],
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
};
// Topics whose header.stamp is a capture time: their age on arrival is shown as latency.
const AGED_TOPICS = new Set(["/lidar/points", "/camera/image/compressed", "/imu/data", "/odom",
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
  const rates = new Map(Object.keys(SUBSCRIPTIONS).map((topic) => [topic, new RateMeter()]));
  const counts = Object.fromEntries(Object.keys(SUBSCRIPTIONS).map((topic) => [topic, 0]));
  const handlerWorstMs = {}; // topic -> longest time one message took to handle, ms
  const panels = {
    map: new MapPanel(document.getElementById("map")),
    camera: new CameraPanel(document.getElementById("camera")),
    imu: new ImuPanel(document.getElementById("imu")),
    latency: new LatencyPanel(document.getElementById("latency"), trace, ages),
    topics: new TopicsPanel(document.getElementById("topics"), connection, rates),
  };
  const vessel = { yawRad: NaN, speedMps: NaN, stampMs: NaN };
  const handlers = {
    "/lidar/points": (m) => panels.map.onCloud(m),
    "/camera/image/compressed": (m) => panels.camera.onImage(m),
    "/imu/data": (m, now) => panels.imu.onImu(m, now),
    "/odom": (m) => Object.assign(vessel, odometryReadout(m)),
    "/tf_static": (m) => panels.map.onStaticTf(m),
    "/nav/boxes": (m) => panels.map.onBoxes(m),
    "/nav/radar_detections": (m) => panels.map.onDetections(m),
    "/nav/lines": (m) => panels.camera.onLines(m),
    "/nav/obstacle_map": (m) => panels.map.onGrid(m),
    "/riverbridge/trace": (m) => trace.onSpans(m),
    "/riverbridge/process_stats": (m) => panels.topics.onProcessStats(m),
  };
  for (const [topic, [type, throttleMs]] of Object.entries(SUBSCRIPTIONS)) {
    const options = { compression: "cbor", throttle_rate: throttleMs, queue_length: 1 };
    connection.subscribe(topic, type, options, (message) => {
      const now = performance.now();
      counts[topic] += 1;
      rates.get(topic).tick(now);
      if (AGED_TOPICS.has(topic)) ages.record(topic, Date.now() - stampMs(message.header));
      handlers[topic](message, now);
      const spent = performance.now() - now;
      handlerWorstMs[topic] = Math.max(handlerWorstMs[topic] ?? 0, spent);
    });
  }
  const commandReadout = document.getElementById("command");
  const steering = new KeyboardSteering(window, connection, (surge, yaw, active) => {
    commandReadout.textContent = active
      ? `⌨ surge ${surge.toFixed(0)} N · yaw ${yaw.toFixed(0)} N·m`
      : "⌨ ←↑→↓ steer · space stop";
    commandReadout.classList.toggle("active", active);
  });
  const frames = runFrames(panels, vessel);
  connection.start();
  window.riverbridgeDashboard = { counts, vessel, trace, ages, frames, steering, connection,
    handlerWorstMs };
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
