// A Foxglove client (npm `@foxglove/ws-protocol`) drives the simulated vessel: it subscribes
// to the ground-truth odometry (CDR decoded with `@foxglove/cdr`), advertises a client channel
// on the command topic and publishes full-ahead wrenches (CDR written with CdrWriter) for a
// few seconds, then reports the odometry before and after.
//
// usage: node foxglove_drive.mjs URL ODOM_TOPIC COMMAND_TOPIC SURGE_N SECONDS
import cdr from "@foxglove/cdr";
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { scenario, succeed } from "./common.mjs";
import { decodeCdr } from "./foxglove_cdr.mjs";

const { CdrWriter } = cdr; // (CommonJS packages: named exports via the default)
const { FoxgloveClient } = wsProtocol;
const [url, odomTopic, commandTopic, surgeText, secondsText] = scenario("foxglove_drive.mjs", [
  "URL",
  "ODOM_TOPIC",
  "COMMAND_TOPIC",
  "SURGE_N",
  "SECONDS",
]);

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const channels = new Map();
let latest;
let odomChannel;
const waiters = [];
const poke = () => waiters.splice(0).forEach((check) => check());
const until = (predicate) =>
  new Promise((resolve) => {
    const check = () => (predicate() ? resolve(predicate()) : waiters.push(check));
    check();
  });
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

client.on("advertise", (list) => { for (const c of list) channels.set(c.topic, c); poke(); });
client.on("message", (event) => { latest = event; poke(); });

odomChannel = await until(() => channels.get(odomTopic));
client.subscribe(odomChannel.id);
await until(() => latest);
const before = decodeCdr(odomChannel.schema, latest.data);

const channelId = client.advertise({ topic: commandTopic, encoding: "cdr", schemaName: "geometry_msgs/msg/Wrench" });
const writer = () => {
  const w = new CdrWriter();
  for (const value of [Number(surgeText), 0, 0, 0, 0, 0]) w.float64(value);
  return w.data;
};
const endAt = Date.now() + Number(secondsText) * 1000;
while (Date.now() < endAt) {
  client.sendMessage(channelId, writer());
  await sleep(100);
}
const after = decodeCdr(odomChannel.schema, latest.data);
client.close();
succeed({ before: before.twist.twist.linear, after: after.twist.twist.linear, beforePose: before.pose.pose.position, afterPose: after.pose.pose.position });
