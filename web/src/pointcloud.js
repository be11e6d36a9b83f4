// PointCloud2 → a decimated (x, y, z) Float32Array by striding, without copying the full scan.

/**
 * Every `stride`-th point of a sensor_msgs/msg/PointCloud2 with float32 x, y, z fields.
 * Returns `points : (k, 3) float32` flattened row-major, k <= maxPoints, NaN points dropped.
 */
export function decimateCloud(cloud, bytes, maxPoints) {
  const count = cloud.width * cloud.height;
  const offsets = Object.fromEntries((cloud.fields ?? []).map((f) => [f.name, f.offset]));
  if (count === 0 || offsets.x === undefined || offsets.y === undefined) {
    return new Float32Array(0);
  }
  const step = cloud.point_step;
  const aligned = bytes.byteOffset % 4 === 0 && step % 4 === 0 && !cloud.is_bigendian;
  const stride = Math.max(1, Math.ceil(count / maxPoints));
  const out = new Float32Array(Math.ceil(count / stride) * 3);
  let k = 0;
  if (aligned) {
    const floats = new Float32Array(bytes.buffer, bytes.byteOffset, Math.floor(bytes.byteLength / 4));
    const words = step / 4;
    const [ox, oy, oz] = [offsets.x / 4, offsets.y / 4, (offsets.z ?? offsets.x) / 4];
    for (let i = 0; i < count; i += stride) {
      const base = i * words;
      const x = floats[base + ox];
      if (Number.isNaN(x)) continue;
      out[k++] = x;
      out[k++] = floats[base + oy];
      out[k++] = floats[base + oz];
    }
  } else {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const little = !cloud.is_bigendian;
    for (let i = 0; i < count; i += stride) {
      const base = i * step;
      const x = view.getFloat32(base + offsets.x, little);
      if (Number.isNaN(x)) continue;
      out[k++] = x;
      out[k++] = view.getFloat32(base + offsets.y, little);
      out[k++] = view.getFloat32(base + (offsets.z ?? offsets.x), little);
    }
  }
  return out.subarray(0, k);
}
