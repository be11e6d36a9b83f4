// Topics with their types and the rates this page receives them at, the connected clients
// (rosapi `topics`, `nodes`), each process's CPU, memory and drops (/riverbridge/process_stats)
// and how often `riverbridge up` restarted each component (/riverbridge/restarts).
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
    ])
      .then(([topics, nodes]) => {
        this.topics = topics.topics.map((name, i) => [name, topics.types[i]]);
        this.nodes = nodes.nodes;
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
      rows.push(`<tr${meter && rate === "0.0" ? " class=\"stale\"" : ""}><td>${esc(name)}</td>` +
        `<td class="num">${rate}</td><td class="type">${esc(type)}</td></tr>`);
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
    this.element.innerHTML = `<table id="topics-table">${rows.join("")}</table>`;
  }
}

function esc(text) {
  return String(text).replace(/[&<>"]/g, (ch) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", "\"": "&quot;" })[ch]);
}
