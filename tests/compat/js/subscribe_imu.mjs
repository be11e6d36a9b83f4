// roslibjs subscribes to a sensor_msgs/msg/Imu (JSON or CBOR) and reports it as received,
// including the kind of container each fixed-size covariance arrived in.
//
// usage: node subscribe_imu.mjs URL TOPIC COMPRESSION
import { Topic } from "roslib";
import { connect, kindOf, scenario, succeed, watchStatus } from "./common.mjs";

const [url, topicName, compression] = scenario("subscribe_imu.mjs", ["URL", "TOPIC", "COMPRESSION"]);
const COVARIANCES = ["orientation_covariance", "angular_velocity_covariance", "linear_acceleration_covariance"];

const ros = await connect(url);
const statusOps = watchStatus(ros);
const topic = new Topic({ ros, name: topicName, messageType: "sensor_msgs/msg/Imu", compression });
topic.subscribe((imu) => {
  topic.unsubscribe();
  const kinds = Object.fromEntries(COVARIANCES.map((name) => [name, kindOf(imu[name])]));
  const asArrays = Object.fromEntries(COVARIANCES.map((name) => [name, Array.from(imu[name] ?? [])]));
  succeed({ compression, message: { ...imu, ...asArrays }, covariance_kinds: kinds, status_ops: statusOps });
});
