// Foxglove's own client library (npm `@foxglove/ws-protocol`, FoxgloveClient) reading and
// setting a ROS 2 node's parameters through the bridge, named as foxglove_bridge names them
// (`/node.param`): get by name, set with an id (answered with the new value) while
// subscribed to its updates, an update of a change someone else makes (`enabled`, set by
// the test through rosapi), and getParameters with no names (every node's). With SILENT, a
// node whose parameter services never answer: its get and set end in status messages.
// One JSON result line (common.mjs's contract).
//
// usage: node foxglove_params.mjs URL NODE|- [SILENT_NODE]
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { scenario, succeed } from "./common.mjs";

const { FoxgloveClient } = wsProtocol;
const [url, node, silent] = scenario("foxglove_params.mjs", ["URL", "NODE|-"]);

const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const result = { statuses: [], errors: [] };
const values = [];
const waiters = [];
const poke = () => waiters.splice(0).forEach((check) => check());
const until = (predicate) =>
  new Promise((resolve) => {
    const check = () => {
      const value = predicate();
      if (value) resolve(value);
      else waiters.push(check);
    };
    check();
  });
const reply = (id) => until(() => values.find((v) => v.id === id));

client.on("error", (error) => result.errors.push(String(error)));
client.on("serverInfo", (info) => { result.capabilities = info.capabilities; poke(); });
client.on("status", (status) => { result.statuses.push(status.message); poke(); });
client.on("parameterValues", (event) => { values.push(event); poke(); });
await until(() => result.capabilities);

if (node !== "-") {
  client.getParameters([`${node}.gain`, `${node}.label`, `${node}.enabled`, `${node}.nope`], "get-1");
  result.get = (await reply("get-1")).parameters;
  result.enabled = result.get.find((p) => p.name === `${node}.enabled`);
  result.get = result.get.filter((p) => p.name !== `${node}.enabled`);
  client.subscribeParameterUpdates([`${node}.gain`]);
  client.setParameters([{ name: `${node}.gain`, value: 3.25, type: "float64" }], "set-1");
  result.set = (await reply("set-1")).parameters;
  result.update = (await until(() => values.find((v) => v.id === undefined))).parameters;
  // A change made by someone else (rosapi, from the test) reaches it through /parameter_events.
  client.subscribeParameterUpdates([`${node}.enabled`]);
  const external = await until(() =>
    values.find((v) => v.id === undefined && v.parameters.some((p) => p.name === `${node}.enabled`)),
  );
  result.external = external.parameters.find((p) => p.name === `${node}.enabled`);
  client.getParameters([], "all");
  result.all = (await reply("all")).parameters.map((p) => p.name);
}
if (silent !== undefined) {
  client.getParameters([`${silent}.x`], "get-silent");
  result.getSilent = (await reply("get-silent")).parameters;
  client.setParameters([{ name: `${silent}.x`, value: 1 }]);
  client.setParameters([{ name: `${silent}.y`, value: { no: "object" } }]);
  await until(() => result.statuses.length >= 3);
}
client.close();
succeed(result);
