// Shared plumbing for the roslibjs scenarios: connect, hard timeout, one JSON result line.
//
// Each scenario script takes the bridge URL as its first argument, does one thing with the
// real roslibjs (npm `roslib`), prints exactly one JSON line on stdout and exits 0, or prints
// a JSON line with `ok: false` and exits 1. A hard timeout guarantees it never hangs.
import { createHash } from "node:crypto";
import { Ros } from "roslib";

// Generous: node, the bridge and pytest share two loaded cores.
export const HARD_TIMEOUT_MS = 60000;

function finish(code, result) {
  process.stdout.write(`${JSON.stringify(result)}\n`);
  process.exit(code);
}

export function succeed(result) {
  finish(0, { ok: true, ...result });
}

export function fail(reason, detail = {}) {
  finish(1, { ok: false, reason: String(reason), ...detail });
}

// Parses argv, arms the hard timeout and reports uncaught errors as a failed scenario.
export function scenario(name, usage) {
  const args = process.argv.slice(2);
  if (args.length < usage.length) {
    fail(`usage: node ${name} ${usage.join(" ")}`);
  }
  setTimeout(() => fail(`${name}: hard timeout after ${HARD_TIMEOUT_MS} ms`), HARD_TIMEOUT_MS);
  process.on("uncaughtException", (error) => fail(`${name}: ${error?.stack ?? error}`));
  process.on("unhandledRejection", (error) => fail(`${name}: ${error?.stack ?? error}`));
  return args;
}

// Resolves with a connected Ros, rejects if the socket errors or closes first.
export function connect(url) {
  return new Promise((resolve, reject) => {
    const ros = new Ros({});
    ros.on("connection", () => resolve(ros));
    ros.on("error", (error) => reject(new Error(`roslib connection error: ${error?.message ?? error}`)));
    ros.on("close", () => reject(new Error("roslib connection closed before it opened")));
    ros.connect(url).catch(reject);
  });
}

// Collects the status ops roslibjs surfaces as events (rosbridge never sends any unasked).
export function watchStatus(ros) {
  const seen = [];
  ros.on("status", (message) => seen.push(message));
  return seen;
}

export function sha256Hex(bytes) {
  return createHash("sha256").update(bytes).digest("hex");
}

// A uint8[] field as roslibjs hands it over: Uint8Array from CBOR, base64 string from JSON.
export function bytesOf(value) {
  if (value instanceof Uint8Array) {
    return { kind: "Uint8Array", bytes: value };
  }
  if (typeof value === "string") {
    return { kind: "string", bytes: new Uint8Array(Buffer.from(value, "base64")) };
  }
  throw new Error(`uint8[] field arrived as ${Object.prototype.toString.call(value)}`);
}

export function kindOf(value) {
  if (Array.isArray(value)) return "Array";
  if (ArrayBuffer.isView(value)) return value.constructor.name;
  return typeof value;
}

// A received message as JSON can carry it: typed arrays become {"$typed": ctor, values}, and
// non-finite numbers become {"$float": "NaN" | "Infinity" | "-Infinity"} (JSON has neither).
export function describe(value) {
  if (typeof value === "number" && !Number.isFinite(value)) return { $float: String(value) };
  if (typeof value === "bigint") return { $bigint: String(value) };
  if (ArrayBuffer.isView(value)) {
    return { $typed: value.constructor.name, values: Array.from(value, describe) };
  }
  if (Array.isArray(value)) return value.map(describe);
  if (value && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([key, inner]) => [key, describe(inner)]));
  }
  return value;
}
