// Connect roslibjs (npm "roslib") to a running riverbridge stack over CBOR and decode a LIDAR
// scan in the browser's way: typed arrays straight from the binary frame.
//
//   riverbridge up                                          # in one terminal
//   npm install roslib ws                                   # once, anywhere on NODE_PATH
//   node clients/examples/roslibjs_listener.mjs ws://127.0.0.1:9090
//
// Prints the topic list, then one /lidar/points scan (point count and nearest return) and one
// /nav/boxes message, and exits 0 (1 on timeout).
import * as ROSLIB from "roslib";

const url = process.argv[2] ?? "ws://127.0.0.1:9090";
const timeoutMs = Number(process.argv[3] ?? 30000);
const ros = new ROSLIB.Ros({ url });
const timer = setTimeout(() => { console.error(`timed out after ${timeoutMs} ms`); process.exit(1); }, timeoutMs);

function once(name, messageType, describe) {
  return new Promise((resolve) => {
    const topic = new ROSLIB.Topic({ ros, name, messageType, compression: "cbor" });
    topic.subscribe((msg) => {
      topic.unsubscribe();
      console.log(`${name}: ${describe(msg)}`);
      resolve();
    });
  });
}

function describeScan(msg) {
  // data is a Uint8Array over the CBOR frame: view it as float32 x, y, z, intensity. A byte
  // string inside a frame need not start on a 4-byte boundary; copy it once when it doesn't.
  const data = msg.data.byteOffset % 4 === 0 ? msg.data : msg.data.slice();
  const floats = new Float32Array(data.buffer, data.byteOffset, data.byteLength / 4);
  const step = msg.point_step / 4;
  let nearest = Infinity;
  for (let i = 0; i < floats.length; i += step) {
    const r = Math.hypot(floats[i], floats[i + 1], floats[i + 2]);
    if (r < nearest) nearest = r;
  }
  return `${msg.width * msg.height} points, nearest return ${nearest.toFixed(2)} m`;
}

ros.on("error", (error) => { console.error(`connection error: ${error}`); process.exit(1); });
ros.on("connection", () => {
  ros.getTopics(async (result) => {
    console.log(`${result.topics.length} topics: ${result.topics.join(", ")}`);
    await once("/lidar/points", "sensor_msgs/msg/PointCloud2", describeScan);
    await once("/nav/boxes", "riverbridge_msgs/msg/BoxArray",
               (msg) => `${msg.boxes.length} boxes around ${msg.num_clusters} clusters`);
    clearTimeout(timer);
    ros.close();
    process.exit(0);
  });
});
