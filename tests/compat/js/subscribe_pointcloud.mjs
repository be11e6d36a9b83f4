// roslibjs subscribes to a sensor_msgs/msg/PointCloud2 (JSON or CBOR) and decodes the points.
//
// usage: node subscribe_pointcloud.mjs URL TOPIC COMPRESSION
// prints: {ok, data_kind, sha256, n_points, samples{index: [x,y,z,intensity]}, sums, ...}
import { Topic } from "roslib";
import { bytesOf, connect, scenario, sha256Hex, succeed, watchStatus } from "./common.mjs";

const [url, topicName, compression] = scenario("subscribe_pointcloud.mjs", ["URL", "TOPIC", "COMPRESSION"]);

// Reads every point through the PointField offsets, as a viewer would.
function decodePoints(cloud, bytes) {
  const nPoints = cloud.width * cloud.height;
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const littleEndian = !cloud.is_bigendian;
  const sums = Object.fromEntries(cloud.fields.map((f) => [f.name, 0]));
  const read = (index) =>
    cloud.fields.map((f) => view.getFloat32(index * cloud.point_step + f.offset, littleEndian));
  for (let index = 0; index < nPoints; index++) {
    const values = read(index);
    cloud.fields.forEach((f, column) => {
      sums[f.name] += values[column];
    });
  }
  const sampleIndices = [0, 1, Math.floor(nPoints / 2), nPoints - 1];
  const samples = Object.fromEntries(sampleIndices.map((index) => [index, read(index)]));
  return { nPoints, sums, samples };
}

const ros = await connect(url);
const statusOps = watchStatus(ros);
const topic = new Topic({ ros, name: topicName, messageType: "sensor_msgs/msg/PointCloud2", compression });
topic.subscribe((cloud) => {
  topic.unsubscribe();
  const { kind, bytes } = bytesOf(cloud.data);
  const { nPoints, sums, samples } = decodePoints(cloud, bytes);
  succeed({
    compression,
    data_kind: kind,
    byte_length: bytes.byteLength,
    sha256: sha256Hex(bytes),
    n_points: nPoints,
    header: cloud.header,
    height: cloud.height,
    width: cloud.width,
    point_step: cloud.point_step,
    row_step: cloud.row_step,
    is_dense: cloud.is_dense,
    is_bigendian: cloud.is_bigendian,
    fields: cloud.fields,
    samples,
    sums,
    status_ops: statusOps,
  });
});
