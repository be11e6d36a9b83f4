// roslibjs behind a thin link: a JSON PointCloud2 subscribed with `fragment_size` and
// `queue_length: 1` (a raw subscribe op: roslibjs's Topic has no fragment_size) beside an IMU
// Topic. The bridge sends the scan's fragments with IMU samples between them; roslibjs must
// reassemble each scan whole and hand the IMU over as it comes.
//
// usage: node thin_link.mjs URL SCAN_TOPIC IMU_TOPIC FRAGMENT_SIZE SCANS
// prints: {ok, scans: [{sha256, n_points}], imu_ages_ms: [...], imu_during_scan}
import { Topic } from "roslib";
import { bytesOf, connect, scenario, sha256Hex, succeed, watchStatus } from "./common.mjs";

const [url, scanTopic, imuTopic, fragmentSize, wanted] = scenario("thin_link.mjs", [
  "URL",
  "SCAN_TOPIC",
  "IMU_TOPIC",
  "FRAGMENT_SIZE",
  "SCANS",
]);

const ros = await connect(url);
const statusOps = watchStatus(ros);
const scans = [];
const imuAgesMs = [];
let imuSinceScan = 0;
let imuDuringScan = 0;

const ageMs = (stamp) => Date.now() - (stamp.sec * 1000 + stamp.nanosec / 1e6);

new Topic({ ros, name: imuTopic, messageType: "sensor_msgs/msg/Imu" }).subscribe((imu) => {
  imuAgesMs.push(ageMs(imu.header.stamp));
  imuSinceScan += 1;
});
ros.on(scanTopic, (op) => {
  const cloud = op.msg; // roslibjs emits the whole publish op under its topic name
  const { bytes } = bytesOf(cloud.data);
  scans.push({ sha256: sha256Hex(bytes), n_points: cloud.width * cloud.height });
  if (scans.length > 1) imuDuringScan += imuSinceScan;
  imuSinceScan = 0;
  if (scans.length >= Number(wanted)) {
    succeed({ scans, imu_ages_ms: imuAgesMs, imu_during_scan: imuDuringScan, status_ops: statusOps });
  }
});
ros.callOnConnection({
  op: "subscribe",
  id: "thin-link-scan",
  topic: scanTopic,
  type: "sensor_msgs/msg/PointCloud2",
  queue_length: 1,
  fragment_size: Number(fragmentSize),
});
