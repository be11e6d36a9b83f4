// Playback control of `riverbridge play` through the bridge, as the Foxglove app does it over
// the SDK's subprotocol `foxglove.sdk.v1`: serverInfo with playbackControl, time and the
// recording's window; pause (no messages while paused), seek (the next message is the
// recorded one at the seek time, decoded with @foxglove/cdr) and speed, each answered with a
// PlaybackState. `@foxglove/ws-protocol` 0.8 predates playback control, so its requests and
// states (binary opcodes 3 and 5, layouts from foxglove-sdk) are written and read here.
//
// usage: node foxglove_playback.mjs URL TOPIC SEEK_OFFSET_S
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { scenario, succeed } from "./common.mjs";
import { decodeCdr } from "./foxglove_cdr.mjs";

const { FoxgloveClient } = wsProtocol;
const [url, topic, seekOffsetText] = scenario("foxglove_playback.mjs", ["URL", "TOPIC", "SEEK_OFFSET_S"]);
const seekOffsetNs = BigInt(Math.round(Number(seekOffsetText) * 1e9));

const ws = new WebSocket(url, ["foxglove.sdk.v1"]);
const client = new FoxgloveClient({ ws });
const channels = new Map();
const messages = [];
const times = [];
const states = [];
const errors = [];
let serverInfo;
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
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

client.on("error", (error) => {
  if (!String(error).includes("opcode in binary message: 5")) errors.push(String(error)); // ours below
});
client.on("serverInfo", (info) => { serverInfo = info; poke(); });
client.on("advertise", (list) => { for (const c of list) channels.set(c.topic, c); poke(); });
client.on("message", (event) => { messages.push({ ...event, at: Date.now() }); poke(); });
client.on("time", (event) => { times.push(event.timestamp); poke(); });
ws.addEventListener("message", (event) => {
  if (!(event.data instanceof ArrayBuffer)) return;
  const view = new DataView(event.data);
  if (view.getUint8(0) !== 5) return;
  const idLength = view.getUint32(15, true);
  states.push({
    status: view.getUint8(1),
    currentTime: view.getBigUint64(2, true),
    speed: view.getFloat32(10, true),
    didSeek: view.getUint8(14) !== 0,
    requestId: new TextDecoder().decode(new Uint8Array(event.data, 19, idLength)),
  });
  poke();
});

function control(play, speed, seekNs, requestId) {
  const id = new TextEncoder().encode(requestId);
  const frame = new Uint8Array(1 + 1 + 4 + 1 + 8 + 4 + id.length);
  const view = new DataView(frame.buffer);
  view.setUint8(0, 3);
  view.setUint8(1, play ? 0 : 1);
  view.setFloat32(2, speed, true);
  view.setUint8(6, seekNs === undefined ? 0 : 1);
  view.setBigUint64(7, seekNs ?? 0n, true);
  view.setUint32(15, id.length, true);
  frame.set(id, 19);
  ws.send(frame);
  return until(() => states.find((s) => s.requestId === requestId));
}

const toNs = (t) => BigInt(t.sec) * 1000000000n + BigInt(t.nsec);
await until(() => serverInfo);
const startNs = toNs(serverInfo.dataStartTime);
const channel = await until(() => channels.get(topic));
client.subscribe(channel.id);
await until(() => messages.length >= 3);
await until(() => times.length >= 1);

const paused = await control(false, 1.0, undefined, "pause-1");
// What was already on its way arrives: wait for 300 ms without a message (at most 5 s).
for (let quietSince = Date.now(), last = messages.length, end = Date.now() + 5000; Date.now() < end; ) {
  await sleep(50);
  if (messages.length !== last) [quietSince, last] = [Date.now(), messages.length];
  else if (Date.now() - quietSince >= 300) break;
}
const countPaused = messages.length;
await sleep(700);
const duringPause = messages.length - countPaused;

const seekTarget = startNs + seekOffsetNs;
const countBeforeSeek = messages.length;
const seeked = await control(true, 1.0, seekTarget, "seek-1");
await until(() => messages.length > countBeforeSeek);
const afterSeek = messages[countBeforeSeek];
const decodedAfterSeek = decodeCdr(channel.schema, afterSeek.data);

const faster = await control(true, 2.0, undefined, "speed-1");
const timeAfter = await until(() => times.length > 0 && times[times.length - 1]);

client.close();
succeed({
  protocol: ws.protocol,
  serverInfo,
  errors,
  paused: { ...paused, currentTime: paused.currentTime.toString() },
  duringPause,
  seeked: { ...seeked, currentTime: seeked.currentTime.toString() },
  seekTarget: seekTarget.toString(),
  afterSeek: { timestamp: afterSeek.timestamp.toString(), message: decodedAfterSeek },
  faster: { ...faster, currentTime: faster.currentTime.toString() },
  lastTime: timeAfter.toString(),
  firstTime: times[0].toString(),
});
