// Link health from the bridge's `GET /metrics` (docs/bridge.md, "Over a thin link"): per
// client its measured goodput, the round trip of its last keepalive ping and the bytes handed
// to its socket but not yet sent; per topic and client the messages conflated (queue_length),
// dropped (send buffer) and thinned (reduce).

/** `ws://host:port/…` -> `http://host:port/metrics` (wss -> https). */
export function metricsUrl(bridgeUrl) {
  const url = new URL(bridgeUrl);
  url.protocol = url.protocol === "wss:" ? "https:" : "http:";
  url.pathname = "/metrics";
  url.search = "";
  return url.toString();
}

const SAMPLE = /^(riverbridge_[a-z_]+)\{([^}]*)\} (\S+)$/;
const LABEL = /(\w+)="((?:[^"\\]|\\.)*)"/g;
const PER_CLIENT = {
  riverbridge_client_goodput_bytes_per_second: "goodputBytesPerS",
  riverbridge_client_rtt_seconds: "rttS",
  riverbridge_client_unsent_bytes: "unsentBytes",
};
const PER_TOPIC = {
  riverbridge_conflated_total: "conflated",
  riverbridge_dropped_total: "dropped",
  riverbridge_reduced_total: "reduced",
};

/**
 * The Prometheus text of /metrics -> {clients: Map(subscriber -> {goodputBytesPerS, rttS,
 * unsentBytes}), topics: Map("topic subscriber" -> {topic, subscriber, conflated, dropped,
 * reduced})}.
 */
export function parseLinkMetrics(text) {
  const clients = new Map();
  const topics = new Map();
  for (const line of text.split("\n")) {
    const match = SAMPLE.exec(line);
    if (!match) continue;
    const [, name, labelText, valueText] = match;
    const labels = Object.fromEntries([...labelText.matchAll(LABEL)].map((m) => [m[1], m[2]]));
    const value = Number(valueText);
    if (name in PER_CLIENT) {
      const client = clients.get(labels.subscriber) ?? {};
      client[PER_CLIENT[name]] = value;
      clients.set(labels.subscriber, client);
    } else if (name in PER_TOPIC) {
      const key = `${labels.topic} ${labels.subscriber}`;
      const row = topics.get(key) ?? { topic: labels.topic, subscriber: labels.subscriber,
        conflated: 0, dropped: 0, reduced: 0 };
      row[PER_TOPIC[name]] = value;
      topics.set(key, row);
    }
  }
  return { clients, topics };
}

/** Fetch and parse the bridge's /metrics; resolves null when it cannot be read. */
export async function fetchLinkHealth(bridgeUrl) {
  try {
    const response = await fetch(metricsUrl(bridgeUrl), { cache: "no-store" });
    return response.ok ? parseLinkMetrics(await response.text()) : null;
  } catch {
    return null;
  }
}
