// Fixed-size numeric history and rate meters: the page's memory stays flat however long it runs.

/** A ring of the last `capacity` (time_ms, value…) rows in one Float64Array. */
export class RollingSeries {
  constructor(capacity, channels) {
    this.capacity = capacity;
    this.channels = channels;
    this.rows = new Float64Array(capacity * (channels + 1));
    this.count = 0;
    this.next = 0;
  }

  push(timeMs, values) {
    const width = this.channels + 1;
    const base = this.next * width;
    this.rows[base] = timeMs;
    for (let c = 0; c < this.channels; c++) this.rows[base + 1 + c] = values[c];
    this.next = (this.next + 1) % this.capacity;
    this.count = Math.min(this.count + 1, this.capacity);
  }

  /** Visit rows oldest first: fn(timeMs, rowBaseIndex) reads `this.rows[base + 1 + c]`. */
  forEach(fn) {
    const width = this.channels + 1;
    const start = (this.next - this.count + this.capacity) % this.capacity;
    for (let i = 0; i < this.count; i++) {
      const base = ((start + i) % this.capacity) * width;
      fn(this.rows[base], base);
    }
  }
}

/** Messages per second over a sliding window of arrival times. */
export class RateMeter {
  constructor(windowMs = 5000, capacity = 512) {
    this.windowMs = windowMs;
    this.times = new Float64Array(capacity);
    this.count = 0;
    this.next = 0;
    this.total = 0;
  }

  tick(nowMs) {
    this.times[this.next] = nowMs;
    this.next = (this.next + 1) % this.times.length;
    this.count = Math.min(this.count + 1, this.times.length);
    this.total += 1;
  }

  rateHz(nowMs) {
    let inWindow = 0;
    let oldest = nowMs;
    for (let i = 0; i < this.count; i++) {
      const t = this.times[i];
      if (nowMs - t <= this.windowMs) {
        inWindow += 1;
        if (t < oldest) oldest = t;
      }
    }
    if (inWindow < 2) return 0;
    return ((inWindow - 1) * 1000) / Math.max(nowMs - oldest, 1);
  }
}
