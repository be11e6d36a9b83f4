// Small readers for ROS 2 message fields as roslibjs hands them over (CBOR or JSON).

/** header.stamp in milliseconds since the epoch (sub-ms digits kept as a fraction). */
export function stampMs(header) {
  const stamp = header?.stamp ?? {};
  return Number(stamp.sec ?? stamp.secs ?? 0) * 1e3 + Number(stamp.nanosec ?? stamp.nsecs ?? 0) / 1e6;
}

/** A uint8[] field: Uint8Array from CBOR, base64 text from JSON. */
export function bytesOf(value) {
  if (value instanceof Uint8Array) return value;
  if (typeof value === "string") return Uint8Array.from(atob(value), (ch) => ch.charCodeAt(0));
  if (Array.isArray(value)) return Uint8Array.from(value);
  return new Uint8Array(0);
}

/** Difference b - a in milliseconds of two int64 nanosecond times (BigInt from CBOR). */
export function nsDiffMs(a, b) {
  if (typeof a === "bigint" || typeof b === "bigint") return Number(BigInt(b) - BigInt(a)) / 1e6;
  return (b - a) / 1e6;
}

/** Yaw (rad, counter-clockwise about z) of a geometry_msgs/Quaternion. */
export function yawOf(q) {
  return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z));
}
