// roslibjs's rosapi helpers (relative names, e.g. `rosapi/topics`) against the bridge.
//
// usage: node rosapi.mjs URL TOPIC MESSAGE_TYPE
// prints: {ok, topics, topic_type, services, nodes, typedefs, decoded}
import { connect, scenario, succeed, watchStatus } from "./common.mjs";

const [url, topicName, messageType] = scenario("rosapi.mjs", ["URL", "TOPIC", "MESSAGE_TYPE"]);

// roslibjs helpers take (…args, callback, failedCallback); turn one into a promise.
function ask(helper, ...args) {
  return new Promise((resolve, reject) => {
    helper(...args, resolve, (error) => reject(new Error(`${helper.name} failed: ${error}`)));
  });
}

const ros = await connect(url);
const statusOps = watchStatus(ros);
const decodeErrors = [];
ros.on("error", (error) => decodeErrors.push(String(error)));

const topics = await ask(ros.getTopics.bind(ros));
const topicType = await ask(ros.getTopicType.bind(ros), topicName);
const services = await ask(ros.getServices.bind(ros));
const nodes = await ask(ros.getNodes.bind(ros));
const typedefs = await ask(ros.getMessageDetails.bind(ros), messageType);
const decoded = ros.decodeTypeDefs(typedefs);
succeed({
  topics,
  topic_type: topicType,
  services,
  nodes,
  typedefs,
  decoded,
  decode_errors: decodeErrors,
  status_ops: statusOps,
});
