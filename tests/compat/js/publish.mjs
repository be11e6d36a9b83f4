// roslibjs advertises a std_msgs/msg/String topic and publishes COUNT messages.
//
// usage: node publish.mjs URL TOPIC COUNT
// prints: {ok, sent: [strings]} once a rosapi round trip shows the bridge has read them all.
import { Service, Topic } from "roslib";
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, topicName, countText] = scenario("publish.mjs", ["URL", "TOPIC", "COUNT"]);
const PERIOD_MS = 20;

const ros = await connect(url);
const statusOps = watchStatus(ros);
const topic = new Topic({ ros, name: topicName, messageType: "std_msgs/msg/String" });
const sent = [];
for (let index = 0; index < Number(countText); index++) {
  // Non-ASCII on purpose: roslibjs sends raw UTF-8 (JSON.stringify does not escape).
  const data = `Grüße aus roslibjs #${index}`;
  topic.publish({ data });
  sent.push(data);
  await new Promise((resolve) => setTimeout(resolve, PERIOD_MS));
}
// The bridge handles one connection's ops in order: once this answers, all publishes are in.
new Service({ ros, name: "rosapi/get_time" }).callService(
  {},
  () => succeed({ sent, status_ops: statusOps }),
  (error) => succeed({ sent, barrier_error: error, status_ops: statusOps }),
);
