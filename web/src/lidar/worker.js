// Dedicated worker for /lidar/points: a ~2.9 MB PointCloud2 at 2 Hz whose CBOR decode,
// decimation and plotting would otherwise block the page's main thread. It holds a roslib
// connection of its own and hands the page only a finished bitmap of the points (transferred,
// not copied), drawn for the map's current view.
//
// page -> worker: {type: "start", url, topic, messageType, throttleMs, maxPoints}
//                 {type: "view", view}   (see PointRaster; re-plots the last scan)
// worker -> page: {type: "state", connected}
//                 {type: "cloud", bitmap: ImageBitmap | null (no view yet), pointCount,
//                  sourcePoints, frameId, stampMs, ageMs, reduced (the bridge's note, or
//                  null), workMs, replot (true: an old scan
//                  drawn again for a new view, not a new message)}
import { Ros } from "roslib";
import { decimateCloud } from "../pointcloud.js";
import { bytesOf, stampMs } from "../rosmsg.js";
import { PointRaster } from "./raster.js";

const RECONNECT_DELAY_MS = 1000;

const raster = new PointRaster();
let view = null;
let lastScan = null; // {points, frameId, sourcePoints, stampMs, ageMs}
let reduced = null; // the bridge's `reduced` note on the last scan, if it thinned it

self.onmessage = ({ data }) => {
  if (data?.type === "start") connect(data);
  if (data?.type === "view") {
    view = data.view;
    if (lastScan) post(lastScan, performance.now(), true);
  }
};

function connect(options) {
  const ros = new Ros({});
  let lost = false;
  const onLost = () => {
    if (lost) return; // close and error both fire for one dead socket
    lost = true;
    self.postMessage({ type: "state", connected: false });
    setTimeout(() => connect(options), RECONNECT_DELAY_MS);
  };
  ros.on("connection", () => {
    self.postMessage({ type: "state", connected: true });
    subscribe(ros, options);
  });
  ros.on("close", onLost);
  ros.on("error", onLost);
  ros.connect(options.url).catch(onLost);
}

function subscribe(ros, { topic, messageType, throttleMs, maxPoints }) {
  // queue_length 1: the bridge drops a stale scan rather than queueing it behind a slow worker
  // or a thin link; reduce "auto": it thins the scan to what this connection's link carries
  // (docs/bridge.md, "Over a thin link"). roslibjs's Topic sends neither `reduce` nor more
  // than its own fields, so the subscribe op goes out as it is and the scans are read off the
  // connection's per-topic events (the whole publish op, with the bridge's `reduced` note).
  ros.callOnConnection({ op: "subscribe", id: `dashboard-lidar-${Date.now()}`, topic,
    type: messageType, compression: "cbor", throttle_rate: throttleMs, queue_length: 1,
    reduce: { point_budget: "auto" } });
  ros.on(topic, (op) => {
    const cloud = op.msg;
    reduced = op.reduced ?? null;
    const started = performance.now(); // roslib has decoded the CBOR by now
    lastScan = {
      points: decimateCloud(cloud, bytesOf(cloud.data), maxPoints),
      frameId: cloud.header.frame_id,
      sourcePoints: cloud.width * cloud.height,
      stampMs: stampMs(cloud.header),
      ageMs: Date.now() - stampMs(cloud.header), // capture -> decoded here
    };
    post(lastScan, started, false);
  });
}

/** Plot `scan` for the current view (if the page has sent one) and post it to the page. */
async function post(scan, started, replot) {
  const bitmap = view ? await createImageBitmap(raster.render(scan.points, scan.frameId, view)) : null;
  const { points, ...about } = scan;
  self.postMessage({ type: "cloud", bitmap, pointCount: points.length / 3,
    ...about, reduced, workMs: performance.now() - started, replot }, bitmap ? [bitmap] : []);
}
