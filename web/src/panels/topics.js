// Topics with their types, the rates this page receives them at and, on hover, what the
// catalogue (schemas/catalogue.py) says of them; the stack's streams nobody publishes; the
// connected clients (rosapi `topics`, `nodes`); each process's CPU, memory and drops
// (/riverbridge/process_stats) and how often `riverbridge up` restarted each component
// (/riverbridge/restarts); and each client's link: goodput, round trip, unsent bytes, and the
// messages conflated, dropped or reduced per topic (the bridge's /metrics).
import { BY_NAME, EXPECTED_TOPICS } from "../catalogue.js";
import { fetchLinkHealth } from "../linkhealth.js";

const POLL_MS = 2000;
const MIB = 1024 * 1024;

export class TopicsPanel {
  constructor(element, connection, rateMeters) {
    this.element = element;
    this.connection = connection;
    this.rates = rateMeters; // topic -> RateMeter, for the topics this page subscribes to
    this.topics = [];
    this.nodes = [];
    this.processes = new Map(); // process name -> latest ProcessStats
    this.restarts = []; // [component, restarts, message] from the latest restarts report
    this.lastPollMs = -Infinity;
    this.polling = false;
    this.link = null; // parseLinkMetrics of the bridge's /metrics
    this.scan = null; // what the bridge said it did to the last scan ({voxel_size_m, ...})
  }

  /** The bridge's word on the last scan the page got (the `reduced` field of its publish). */
  onScanReduced(reduced) {
    this.scan = reduced;
  }

  onProcessStats(message) {
    this.processes.set(`${message.process} (${message.pid})`, message);
  }

  onRestarts(message) {
    this.restarts = message.status.map((status) => {
      const count = status.values.find((kv) => kv.key === "restarts")?.value ?? "0";
      return [status.name.replace(/^up\//, ""), Number(count), status.message];
    });
  }

  draw(nowMs) {
    if (nowMs - this.lastPollMs < POLL_MS || this.polling || !this.connection.connected) return;
    this.lastPollMs = nowMs;
    this.polling = true;
    Promise.all([
      this.connection.call("/rosapi/topics", "rosapi_msgs/srv/Topics", {}),
      this.connection.call("/rosapi/nodes", "rosapi_msgs/srv/Nodes", {}),
      fetchLinkHealth(this.connection.url),
    ])
      .then(([topics, nodes, link]) => {
        this.topics = topics.topics.map((name, i) => [name, topics.types[i]]);
        this.nodes = nodes.nodes;
        this.link = link;
        this.#render(performance.now());
      })
      .catch(() => {})
      .finally(() => {
        this.polling = false;
      });
  }

  #render(nowMs) {
    const rows = [];
    rows.push(`<tr class="section"><td colspan="3">${this.topics.length} topics</td></tr>`);
    rows.push("<tr><th>topic</th><th class=\"num\">Hz here</th><th>type</th></tr>");
    for (const [name, type] of this.topics) {
      const meter = this.rates.get(name);
      const rate = meter ? meter.rateHz(nowMs).toFixed(1) : "";
      const stale = meter && rate === "0.0" ? " class=\"stale\"" : "";
      rows.push(`<tr${stale}${about(BY_NAME.get(name))}><td>${esc(name)}</td>` +
        `<td class="num">${rate}</td><td class="type">${esc(type)}</td></tr>`);
    }
    const listed = new Set(this.topics.map(([name]) => name));
    const missing = EXPECTED_TOPICS.filter((t) => !listed.has(t.name));
    if (missing.length > 0) {
      rows.push(`<tr class="section"><td colspan="3">${missing.length} expected, not published</td></tr>`);
      for (const t of missing) {
        rows.push(`<tr class="stale"${about(t)}><td>${esc(t.name)}</td><td class="num"></td>` +
          `<td class="type">${esc(t.type)}</td></tr>`);
      }
    }
    rows.push(`<tr class="section"><td colspan="3">${this.nodes.length} nodes and clients</td></tr>`);
    for (const node of this.nodes) rows.push(`<tr><td colspan="3">${esc(node)}</td></tr>`);
    if (this.processes.size > 0) {
      rows.push("<tr class=\"section\"><td colspan=\"3\">processes</td></tr>");
      rows.push("<tr><th>process</th><th class=\"num\">dropped</th><th>CPU · RSS</th></tr>");
      for (const [name, s] of this.processes) {
        rows.push(`<tr><td>${esc(name)}</td><td class="num">${s.dropped}</td>` +
          `<td>${Number(s.cpu_percent).toFixed(0)} % · ${(Number(s.rss_bytes) / MIB).toFixed(0)} MiB</td></tr>`);
      }
    }
    if (this.restarts.length > 0) {
      rows.push("<tr class=\"section\"><td colspan=\"3\">restarts by riverbridge up</td></tr>");
      for (const [name, count, message] of this.restarts) {
        rows.push(`<tr${count > 0 ? " class=\"stale\"" : ""}><td>${esc(name)}</td>` +
          `<td class="num restarts">${count}</td><td>${esc(message)}</td></tr>`);
      }
    }
    rows.push(...this.#linkRows());
    this.element.innerHTML = `<table id="topics-table">${rows.join("")}</table>`;
  }

  #linkRows() {
    const rows = [];
    if (this.link && this.link.clients.size > 0) {
      rows.push("<tr class=\"section\"><td colspan=\"3\">links (bridge /metrics)</td></tr>");
      rows.push("<tr><th>client</th><th class=\"num\">goodput</th><th>RTT · unsent</th></tr>");
      for (const [name, c] of this.link.clients) {
        const goodput = c.goodputBytesPerS === undefined ? "—"
          : `${(c.goodputBytesPerS * 8 / 1e6).toFixed(1)} Mbit/s`;
        const rtt = c.rttS ? `${(c.rttS * 1000).toFixed(0)} ms` : "—";
        rows.push(`<tr class="link-client"><td>${esc(name)}</td><td class="num">${goodput}</td>` +
          `<td>RTT ${rtt} · ${((c.unsentBytes ?? 0) / 1024).toFixed(0)} KiB unsent</td></tr>`);
      }
      const lossy = [...this.link.topics.values()].filter((t) => t.conflated || t.dropped || t.reduced);
      for (const t of lossy) {
        rows.push(`<tr class="link-topic"><td>${esc(t.topic)} → ${esc(t.subscriber)}</td>` +
          `<td class="num">${t.conflated}</td><td>conflated · ${t.dropped} dropped · ` +
          `${t.reduced} reduced</td></tr>`);
      }
    }
    if (this.scan) {
      const s = this.scan;
      rows.push(`<tr class="link-scan"><td colspan="3">scan reduced to fit the link: voxel ` +
        `${Number(s.voxel_size_m).toFixed(2)} m, ${s.points_kept} of ${s.points_in} points</td></tr>`);
    }
    return rows;
  }
}

/** A row's tooltip from its catalogue entry: "LIDAR scan, sensor frame · simulator · sensor". */
function about(entry) {
  return entry ? ` title="${esc(`${entry.summary} · ${entry.producer} · ${entry.role}`)}"` : "";
}

function esc(text) {
  return String(text).replace(/[&<>"]/g, (ch) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", "\"": "&quot;" })[ch]);
}
