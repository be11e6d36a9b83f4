// roslibjs subscribes with the given type and compression and reports the first message
// (typed arrays and non-finite floats marked, see common.mjs describe).
//
// usage: node subscribe_first.mjs URL TOPIC TYPE COMPRESSION
import { Topic } from "roslib";
import { connect, describe, scenario, succeed, watchStatus } from "./common.mjs";

const [url, topicName, messageType, compression] = scenario("subscribe_first.mjs", ["URL", "TOPIC", "TYPE", "COMPRESSION"]);

const ros = await connect(url);
const statusOps = watchStatus(ros);
const topic = new Topic({ ros, name: topicName, messageType, compression });
topic.subscribe((message) => {
  topic.unsubscribe();
  succeed({ compression, message: describe(message), status_ops: statusOps });
});
