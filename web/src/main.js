// The dashboard: one rosbridge connection (CBOR, throttled per topic), a worker with a connection
// of its own for the LIDAR scans, six panels, one requestAnimationFrame loop that redraws only
// what changed. `window.riverbridgeDashboard` exposes counters for the browser tests and the
// frame-time benchmark.
import "./style.css";
import { DASHBOARD_TOPICS, topic } from "./catalogue.js";
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

// The page subscribes to every catalogue topic whose consumers include "dashboard" (names and
// types from the catalogue), at most as often as THROTTLE_MS (catalogue key -> throttle_rate,
// ms) allows. queue_length 1 makes the bridge drop stale messages for a slow page or a thin
// link instead of queueing (not for the IMU: every sample). The LIDAR's 2.9 MB scans, thinned
// by the bridge to what the worker's link carries, are decoded and decimated in a worker.
const THROTTLE_MS = { radar: 250, camera: 100, imu: 10, odom: 50, tf_static: 0, boxes: 100,
  radar_detections: 100, lines: 100, obstacle_map: 250, trace: 0, process_stats: 0, restarts: 0,
  guidance_path: 0, guidance_mode: 0 };
const LIDAR = { topic: topic("lidar").name, messageType: topic("lidar").type,
  throttleMs: 250, maxPoints: 40000 }; // 40k of a ~180k scan: more adds no visible detail
const SUBSCRIPTIONS = DASHBOARD_TOPICS.filter((t) => t.name !== LIDAR.topic);
const ALL_TOPICS = DASHBOARD_TOPICS.map((t) => t.name);
// Topics whose header.stamp is a capture time: their age on arrival is shown as latency.
const AGED_TOPICS = new Set(["radar", "camera", "imu", "odom", "boxes", "radar_detections",
  "lines", "obstacle_map"].map((key) => topic(key).name));

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
  const vessel = { xM: NaN, yM: NaN, yawRad: NaN, speedMps: NaN, stampMs: NaN };
  const handlers = messageHandlers(panels, trace, vessel);
  const received = (topic, handle) => {
    const now = performance.now();
    counts[topic] += 1;
    rates.get(topic).tick(now);
    handle(now);
    handlerWorstMs[topic] = Math.max(handlerWorstMs[topic] ?? 0, performance.now() - now);
  };
  for (const { key, name, type } of SUBSCRIPTIONS) {
    const handle = handlers[key];
    if (!handle || !(key in THROTTLE_MS)) throw new Error(`no handler or throttle for ${name}`);
    // every IMU sample (it is small and frequent: the bridge sends it first on a thin link);
    // the newest only of everything else
    const queueLength = key === "imu" ? 0 : 1;
    const options = { compression: "cbor", throttle_rate: THROTTLE_MS[key], queue_length: queueLength };
    connection.subscribe(name, type, options, (message) => received(name, (now) => {
      if (AGED_TOPICS.has(name)) ages.record(name, Date.now() - stampMs(message.header));
      handle(message, now);
    }));
  }
  const lidar = startLidarWorker({ url, ...LIDAR }, (cloud) => {
    if (cloud.replot) {
      if (cloud.bitmap) panels.map.onPointsImage(cloud.bitmap, cloud.pointCount);
      return;
    }
    received(LIDAR.topic, () => {
      ages.record(LIDAR.topic, cloud.ageMs); // capture -> decoded in the worker
      panels.topics.onScanReduced(cloud.reduced);
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

/** Catalogue key -> fn(message, receivedMs) for the topics of the page's own connection. */
function messageHandlers(panels, trace, vessel) {
  return {
    radar: (m) => panels.radar.onImage(m),
    camera: (m) => panels.camera.onImage(m),
    imu: (m, now) => panels.imu.onImu(m, now),
    odom: (m) => {
      Object.assign(vessel, odometryReadout(m));
      panels.map.onPose(vessel);
    },
    tf_static: (m) => panels.map.onStaticTf(m),
    boxes: (m) => panels.map.onBoxes(m),
    radar_detections: (m) => {
      panels.map.onDetections(m);
      panels.radar.onDetections(m);
    },
    lines: (m) => panels.camera.onLines(m),
    obstacle_map: (m) => panels.map.onGrid(m),
    trace: (m) => trace.onSpans(m),
    process_stats: (m) => panels.topics.onProcessStats(m),
    restarts: (m) => panels.topics.onRestarts(m),
    guidance_path: (m) => panels.map.onPath(m),
    guidance_mode: (m) => showMode(m.data),
  };
}

/** The autopilot's mode in the header (docs/guidance.md: follow, avoid, blocked, stale, stop,
 * manual); the keyboard overrides it for a few seconds. */
function showMode(mode) {
  const readout = document.getElementById("autopilot");
  readout.textContent = `autopilot: ${mode}`;
  readout.classList.toggle("active", mode === "follow" || mode === "avoid");
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
  const p = odometry.pose.pose.position;
  return {
    xM: p.x,
    yM: p.y,
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
