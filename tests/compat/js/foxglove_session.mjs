// Foxglove's own client library (npm `@foxglove/ws-protocol`, FoxgloveClient) against the
// bridge: serverInfo, channels with ros2msg schemas, a subscription whose CDR is decoded with
// `@foxglove/cdr` walking the advertised schema (parsed with `@lichtblick/rosmsg`), hostile
// frames answered with status, client publish (CDR), a service call, parameters, the
// connection graph and fetchAsset. One JSON result line (common.mjs's contract).
//
// usage: node foxglove_session.mjs URL SUB_TOPIC PUB_TOPIC ASSET_URI
import cdr from "@foxglove/cdr";
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { scenario, succeed } from "./common.mjs";
import { decodeCdr } from "./foxglove_cdr.mjs";

const { CdrWriter } = cdr; // (CommonJS packages: named exports via the default)
const { FoxgloveClient } = wsProtocol;

const [url, subTopic, pubTopic, assetUri] = scenario("foxglove_session.mjs", [
  "URL",
  "SUB_TOPIC",
  "PUB_TOPIC",
  "ASSET_URI",
]);

function wrenchCdr(force, torque) {
  const writer = new CdrWriter();
  for (const value of [...force, ...torque]) writer.float64(value);
  return writer.data;
}

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const result = { channels: {}, statuses: [], services: {}, errors: [] };
const channels = new Map();
const services = new Map();
const waiters = [];
const until = (predicate) =>
  new Promise((resolve) => {
    const check = () => {
      const value = predicate();
      if (value) resolve(value);
      else waiters.push(check);
    };
    check();
  });
const poke = () => waiters.splice(0).forEach((check) => check());
const events = { parameterValues: [], graph: [], assets: {}, serviceResponses: [], failures: [], messages: [] };

client.on("error", (error) => result.errors.push(String(error)));
client.on("serverInfo", (info) => { result.serverInfo = info; poke(); });
client.on("status", (status) => { result.statuses.push(status); poke(); });
client.on("advertise", (list) => { for (const c of list) channels.set(c.topic, c); poke(); });
client.on("unadvertise", (ids) => { for (const [t, c] of channels) if (ids.includes(c.id)) channels.delete(t); poke(); });
client.on("advertiseServices", (list) => { for (const s of list) services.set(s.name, s); poke(); });
client.on("message", (event) => { events.messages.push(event); poke(); });
client.on("parameterValues", (event) => { events.parameterValues.push(event); poke(); });
client.on("connectionGraphUpdate", (event) => { events.graph.push(event); poke(); });
client.on("fetchAssetResponse", (event) => { events.assets[event.requestId] = event; poke(); });
client.on("serviceCallResponse", (event) => { events.serviceResponses.push(event); poke(); });
client.on("serviceCallFailure", (event) => { events.failures.push(event); poke(); });

await until(() => result.serverInfo);
result.protocol = ws.protocol;

// Channels with their schemas; a subscription decoded with @foxglove/cdr.
const imu = await until(() => channels.get(subTopic));
result.channels[subTopic] = imu;
const subscription = client.subscribe(imu.id);
const first = await until(() => events.messages.find((m) => m.subscriptionId === subscription));
result.decoded = decodeCdr(imu.schema, first.data);
result.timestamp = first.timestamp.toString();
client.unsubscribe(subscription);

// Hostile input: each is answered with a status, and the connection goes on.
ws.send("{not json");
ws.send(JSON.stringify({ op: "frobnicate" }));
ws.send(new Uint8Array([9, 1, 2, 3]));
ws.send(JSON.stringify({ op: "subscribe", subscriptions: [{ id: 99, channelId: 987654 }] }));
client.sendMessage(4242, new Uint8Array([0, 1, 0, 0]));
await until(() => result.statuses.length >= 5);

// Client publish (CDR) onto the graph.
const channelId = client.advertise({ topic: pubTopic, encoding: "cdr", schemaName: "geometry_msgs/msg/Wrench" });
for (let i = 0; i < 30; i += 1) {
  client.sendMessage(channelId, wrenchCdr([120.5, 0, 0], [0, 0, -7.25]));
  await new Promise((resolve) => setTimeout(resolve, 100));
}

// A service answered by the bridge, request and response in CDR.
const getTime = await until(() => services.get("/rosapi/get_time"));
result.services["/rosapi/get_time"] = getTime;
client.sendServiceCallRequest({ serviceId: getTime.id, callId: 7, encoding: "cdr", data: new Uint8Array([0, 1, 0, 0, 0]) });
const answer = await until(() => events.serviceResponses.find((r) => r.callId === 7));
result.serviceResponse = decodeCdr(getTime.response.schema, answer.data);
client.sendServiceCallRequest({ serviceId: 123456, callId: 8, encoding: "cdr", data: new Uint8Array([0, 1, 0, 0]) });
result.serviceFailure = await until(() => events.failures.find((f) => f.callId === 8));

// Parameters: set with an id (answered), read back, and updates of one another client sets.
client.subscribeParameterUpdates(["/compat:from_ros"]);
client.setParameters([{ name: "/compat:answer", value: 42 }, { name: "/compat:list", value: [1.5, 2.5] }], "set-1");
result.setReply = await until(() => events.parameterValues.find((p) => p.id === "set-1"));
client.getParameters(["/compat:answer", "/compat:list"], "get-1");
result.getReply = await until(() => events.parameterValues.find((p) => p.id === "get-1"));
result.update = await until(() =>
  events.parameterValues.find((p) => p.id === undefined && p.parameters.some((x) => x.name === "/compat:from_ros")),
);

// The connection graph.
client.subscribeConnectionGraph();
result.graph = await until(() => events.graph[0]);

// Assets: one allowed, one outside the allow-list.
client.fetchAsset(assetUri, 1);
client.fetchAsset("file:///etc/passwd", 2);
const good = await until(() => events.assets[1]);
const bad = await until(() => events.assets[2]);
result.assetOk = { status: good.status, text: good.status === 0 ? new TextDecoder().decode(good.data) : good.error };
result.assetRefused = { status: bad.status, error: bad.error };

client.close();
succeed(result);
