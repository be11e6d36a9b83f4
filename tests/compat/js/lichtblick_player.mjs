// Lichtblick's rosbridge player pipeline with the libraries it ships: @lichtblick/roslibjs
// (its roslibjs fork), @lichtblick/rosmsg (definition parser) and
// @lichtblick/rosmsg2-serialization (CDR reader).
//
// usage: node lichtblick_player.mjs URL TOPIC
// 1. discover topics via /rosapi/topics_and_raw_types (type "rosapi/TopicsAndRawTypes"),
// 2. decide ROS 2 from /rosout's type, parse TOPIC's definition text in that mode,
// 3. subscribe TOPIC with compression "cbor-raw" and no type, 4. decode msg.bytes as CDR.
// prints: {ok, ros_version, topic_type, definition_names, message}
import { createRequire } from "node:module";
import { WebSocket } from "ws";
import { fail, scenario, succeed } from "./common.mjs";

// The fork's bundle picks the global WebSocket (browser); Node 20 has none, so lend it ws's.
globalThis.WebSocket = WebSocket;
const require = createRequire(import.meta.url);
const ROSLIB = require("@lichtblick/roslibjs");
const { parse } = require("@lichtblick/rosmsg");
const { MessageReader } = require("@lichtblick/rosmsg2-serialization");

const [url, topicName] = scenario("lichtblick_player.mjs", ["URL", "TOPIC"]);

// Typed arrays and bigints are not JSON: report them as plain arrays / numbers.
function plain(value) {
  if (typeof value === "bigint") return Number(value);
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([key, inner]) => [key, plain(inner)]));
  }
  return value;
}

function discover(ros) {
  return new Promise((resolve, reject) => {
    const service = new ROSLIB.Service({
      ros,
      name: "/rosapi/topics_and_raw_types",
      serviceType: "rosapi/TopicsAndRawTypes",
    });
    service.callService(new ROSLIB.ServiceRequest({}), resolve, (error) => reject(new Error(error)));
  });
}

const ros = new ROSLIB.Ros({ url, transportLibrary: "websocket" });
ros.on("error", (error) => fail(`connection error: ${error?.message ?? error}`));
ros.on("connection", async () => {
  const result = await discover(ros);
  const types = result.types;
  const rosVersion = types.includes("rcl_interfaces/msg/Log") ? 2 : types.includes("rosgraph_msgs/Log") ? 1 : null;
  const index = result.topics.indexOf(topicName);
  if (index < 0) fail(`${topicName} not in topics_and_raw_types`, { topics: result.topics });
  const definitions = parse(result.typedefs_full_text[index], { ros2: rosVersion === 2 });
  const reader = new MessageReader(definitions);
  const topic = new ROSLIB.Topic({ ros, name: topicName, compression: "cbor-raw" });
  topic.subscribe((raw) => {
    topic.unsubscribe();
    succeed({
      ros_version: rosVersion,
      topic_type: types[index],
      definition_names: definitions.map((definition) => definition.name ?? null),
      raw_keys: Object.keys(raw).sort(),
      message: plain(reader.readMessage(raw.bytes)),
    });
  });
});
