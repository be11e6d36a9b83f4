// One rosbridge connection (roslibjs) that survives bridge restarts: subscriptions and
// advertisements are declared once and re-made after every reconnect.
import { Ros, Service, Topic } from "roslib";

const RECONNECT_DELAY_MS = 1000;

/** The bridge's websocket URL: `?bridge=ws://…` if given, else the host that served the page. */
export function bridgeUrl(location) {
  const explicit = new URLSearchParams(location.search).get("bridge");
  if (explicit) return explicit;
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  return `${scheme}://${location.host}`;
}

export class Connection {
  /** @param {string} url  @param {(connected: boolean) => void} onState */
  constructor(url, onState) {
    this.url = url;
    this.onState = onState;
    this.connected = false;
    this.ros = null;
    this.specs = []; // {name, messageType, options, callback, topic}
    this.publishers = new Map(); // name -> {messageType, topic}
  }

  start() {
    const ros = new Ros({});
    this.ros = ros;
    ros.on("connection", () => {
      this.connected = true;
      for (const spec of this.specs) this.#subscribe(spec);
      for (const publisher of this.publishers.values()) publisher.topic = null;
      this.onState(true);
    });
    ros.on("close", () => this.#lost(ros));
    ros.on("error", () => this.#lost(ros));
    ros.connect(this.url).catch(() => this.#lost(ros));
  }

  #lost(ros) {
    if (this.ros !== ros) return; // an old socket's late event
    this.ros = null;
    this.connected = false;
    this.onState(false);
    setTimeout(() => this.start(), RECONNECT_DELAY_MS);
  }

  /**
   * Subscribe for the lifetime of the page. `options` are roslibjs Topic options, e.g.
   * `{compression: "cbor", throttle_rate: 100, queue_length: 1}`.
   */
  subscribe(name, messageType, options, callback) {
    const spec = { name, messageType, options, callback, topic: null };
    this.specs.push(spec);
    if (this.connected) this.#subscribe(spec);
  }

  #subscribe(spec) {
    spec.topic = new Topic({ ros: this.ros, name: spec.name, messageType: spec.messageType,
      ...spec.options });
    spec.topic.subscribe(spec.callback);
  }

  /** Publish, advertising on first use (and again after a reconnect). */
  publish(name, messageType, message) {
    if (!this.connected) return false;
    let publisher = this.publishers.get(name);
    if (!publisher) {
      publisher = { messageType, topic: null };
      this.publishers.set(name, publisher);
    }
    if (!publisher.topic) {
      publisher.topic = new Topic({ ros: this.ros, name, messageType });
    }
    publisher.topic.publish(message);
    return true;
  }

  /** Call a service; resolves with its response, rejects on failure or when disconnected. */
  call(name, serviceType, request) {
    if (!this.connected) return Promise.reject(new Error("not connected"));
    const service = new Service({ ros: this.ros, name, serviceType });
    return new Promise((resolve, reject) => service.callService(request, resolve, reject));
  }
}
