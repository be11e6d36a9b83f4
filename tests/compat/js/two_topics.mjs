// Two roslibjs Topic objects on one name and one connection (roslibjs's pubsub example):
// each gets every message once (the bridge delivers once per connection, roslibjs fans out);
// unsubscribing one leaves the other receiving.
//
// usage: node two_topics.mjs URL TOPIC
// prints: {ok, first: [...], second: [...]} — what each Topic object received, including the
// "probe" messages used to learn when both subscriptions are in place.
import { Topic } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, topicName] = scenario("two_topics.mjs", ["URL", "TOPIC"]);
// After the last expected message, how long to keep listening for duplicates or strays.
const GRACE_MS = 500;
const TYPE = "std_msgs/msg/String";

const ros = await connect(url);
const statusOps = watchStatus(ros);
const first = new Topic({ ros, name: topicName, messageType: TYPE });
const second = new Topic({ ros, name: topicName, messageType: TYPE });
const talker = new Topic({ ros, name: topicName, messageType: TYPE });
const received = { first: [], second: [] };
const waiters = [];

function record(which) {
  return (message) => {
    received[which].push(message.data);
    waiters.filter((w) => w.which === which && w.data === message.data).forEach((w) => w.resolve());
  };
}
function arrival(which, data) {
  if (received[which].includes(data)) return Promise.resolve();
  return new Promise((resolve) => waiters.push({ which, data, resolve }));
}
const pause = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

const onFirst = record("first");
first.subscribe(onFirst);
second.subscribe(record("second"));
// The subscribes carry no acknowledgement: repeat a probe until both objects hear it.
while (!received.first.length || !received.second.length) {
  talker.publish({ data: "probe" });
  await pause(200);
}

for (const data of ["one", "two", "three"]) talker.publish({ data });
await Promise.all([arrival("first", "three"), arrival("second", "three")]);
first.unsubscribe(onFirst);
// ros queues nothing between these sends: the unsubscribe reaches the bridge before "four".
talker.publish({ data: "four" });
await arrival("second", "four");
await pause(GRACE_MS);
succeed({ first: received.first, second: received.second, status_ops: statusOps });
