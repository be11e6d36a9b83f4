// Joins riverbridge_msgs/TraceSpan records by (topic, stamp_ns) into per-topic stage latencies
// (docs/tracing.md): stage durations, the two hops between processes, and end to end. Memory is
// bounded: at most MAX_OPEN messages are joined at once, and each statistic keeps a short ring.
import { nsDiffMs } from "./rosmsg.js";

const MAX_OPEN = 1500; // messages being joined (~10 s of every traced topic); oldest forgotten
const SAMPLES = 120; // per statistic: ~1 min of a 2 Hz topic

/** Display order of a message's journey; hops are gaps between spans of different processes. */
export const STAGES = ["generate", "encode", "send", "→bridge", "bridge_in", "fanout", "→client",
  "decode", "wait", "process"];

class Ring {
  constructor(capacity) {
    this.values = new Float64Array(capacity);
    this.count = 0;
    this.next = 0;
  }

  push(value) {
    if (!Number.isFinite(value)) return;
    this.values[this.next] = value;
    this.next = (this.next + 1) % this.values.length;
    this.count = Math.min(this.count + 1, this.values.length);
  }

  median() {
    if (this.count === 0) return NaN;
    const sorted = this.values.slice(0, this.count).sort();
    return sorted[Math.floor(this.count / 2)];
  }
}

export class TraceStats {
  constructor() {
    this.open = new Map(); // "topic|stamp" -> {topic, spans: Map(stage -> [span])}
    this.topics = new Map(); // topic -> Map(statistic -> Ring)
    this.spansSeen = 0;
    this.host = "";
  }

  /** Feed one riverbridge_msgs/msg/TraceSpanArray. */
  onSpans(message) {
    this.host = message.host ?? this.host;
    for (const span of message.spans ?? []) {
      this.spansSeen += 1;
      this.#ring(span.topic, span.stage).push(nsDiffMs(span.start_ns, span.end_ns));
      const key = `${span.topic}|${span.stamp_ns}`;
      let entry = this.open.get(key);
      if (!entry) {
        entry = { topic: span.topic, spans: new Map() };
        this.open.set(key, entry);
        if (this.open.size > MAX_OPEN) this.open.delete(this.open.keys().next().value);
      }
      const list = entry.spans.get(span.stage) ?? [];
      list.push(span);
      entry.spans.set(span.stage, list);
      this.#joinHops(entry, span);
    }
  }

  /** Derived statistics that need two spans, computed when the second one arrives. */
  #joinHops(entry, span) {
    const first = (stage) => entry.spans.get(stage)?.[0];
    const { topic } = entry;
    if (span.stage === "bridge_in" || span.stage === "send") {
      const [send, bridgeIn] = [first("send"), first("bridge_in")];
      if (send && bridgeIn) this.#ring(topic, "→bridge").push(nsDiffMs(send.end_ns, bridgeIn.start_ns));
    }
    if (span.stage === "decode" || span.stage === "fanout") {
      const decode = span.stage === "decode" ? span : first("decode");
      const fanouts = entry.spans.get("fanout") ?? [];
      const fanout = fanouts.find((f) => decode && f.peer === decode.process) ?? fanouts[0];
      if (decode && fanout) this.#ring(topic, "→client").push(nsDiffMs(fanout.end_ns, decode.start_ns));
    }
    const generate = first("generate");
    const decode = first("decode");
    if (generate && decode && (span === generate || span === decode)) {
      this.#ring(topic, "end_to_end").push(nsDiffMs(generate.end_ns, decode.end_ns));
    }
  }

  #ring(topic, statistic) {
    let stats = this.topics.get(topic);
    if (!stats) {
      stats = new Map();
      this.topics.set(topic, stats);
    }
    let ring = stats.get(statistic);
    if (!ring) {
      ring = new Ring(SAMPLES);
      stats.set(statistic, ring);
    }
    return ring;
  }

  /** {topic: {stage or "end_to_end": median ms}} for the topics seen so far. */
  medians() {
    const out = {};
    for (const [topic, stats] of this.topics) {
      out[topic] = Object.fromEntries([...stats].map(([name, ring]) => [name, ring.median()]));
    }
    return out;
  }
}

/** Capture (header.stamp) → decoded in this page, per topic: what the operator actually sees. */
export class ArrivalAges {
  constructor() {
    this.topics = new Map();
  }

  record(topic, ageMs) {
    let ring = this.topics.get(topic);
    if (!ring) {
      ring = new Ring(SAMPLES);
      this.topics.set(topic, ring);
    }
    ring.push(ageMs);
  }

  medians() {
    return Object.fromEntries([...this.topics].map(([topic, ring]) => [topic, ring.median()]));
  }
}
