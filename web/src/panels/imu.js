// IMU angular rates and linear accelerations as rolling plots (thesis figure 15), 20 s window.
import { beginPanelFrame, COLORS } from "../canvas.js";
import { topic } from "../catalogue.js";
import { RollingSeries } from "../rolling.js";

const WINDOW_MS = 20000;
const CAPACITY = 1200; // 20 s at the IMU's 50 Hz plus headroom
const GRAVITY_MPS2 = 9.80665; // taken off z so that all three accelerations share one scale

export class ImuPanel {
  constructor(canvas) {
    this.canvas = canvas;
    this.rates = new RollingSeries(CAPACITY, 3); // rad/s about x, y, z
    this.accels = new RollingSeries(CAPACITY, 3); // m/s² along x, y, z − g
    this.dirty = true;
  }

  onImu(message, receivedMs) {
    const w = message.angular_velocity;
    const a = message.linear_acceleration;
    this.rates.push(receivedMs, [w.x, w.y, w.z]);
    this.accels.push(receivedMs, [a.x, a.y, a.z - GRAVITY_MPS2]);
    this.dirty = true;
  }

  draw(nowMs) {
    const frame = beginPanelFrame(this, topic("imu").name, this.rates.count > 0);
    if (!frame) return;
    const { ctx, width, height } = frame;
    const half = height / 2;
    plot(ctx, this.rates, { x: 0, y: 0, w: width, h: half - 2 }, nowMs, "angular rate [rad/s]");
    plot(ctx, this.accels, { x: 0, y: half + 2, w: width, h: half - 2 }, nowMs, "acceleration [m/s²] (z − g)");
  }
}

/** Three channels of `series` as polylines in `box`, symmetric y range, newest at the right. */
function plot(ctx, series, box, nowMs, title) {
  let peak = 1e-3;
  series.forEach((_t, base) => {
    for (let c = 1; c <= 3; c++) peak = Math.max(peak, Math.abs(series.rows[base + c]));
  });
  peak *= 1.15;
  const left = box.x + 44;
  const plotW = box.w - left - 8;
  const mid = box.y + box.h / 2;
  const yOf = (v) => mid - (v / peak) * (box.h / 2 - 14);
  ctx.strokeStyle = COLORS.axis;
  ctx.beginPath();
  ctx.moveTo(left, mid);
  ctx.lineTo(left + plotW, mid);
  ctx.stroke();
  ctx.fillStyle = COLORS.text;
  ctx.font = "11px system-ui, sans-serif";
  ctx.fillText(title, left, box.y + 12);
  ctx.fillText(formatTick(peak), box.x + 4, yOf(peak) + 10);
  ctx.fillText(formatTick(-peak), box.x + 4, yOf(-peak));
  ctx.lineWidth = 1.2;
  for (let c = 1; c <= 3; c++) {
    ctx.strokeStyle = COLORS.series[c - 1];
    ctx.beginPath();
    let started = false;
    series.forEach((t, base) => {
      const x = left + plotW * (1 - (nowMs - t) / WINDOW_MS);
      if (x < left) return;
      const y = yOf(series.rows[base + c]);
      if (started) ctx.lineTo(x, y);
      else ctx.moveTo(x, y);
      started = true;
    });
    ctx.stroke();
    ctx.fillStyle = COLORS.series[c - 1];
    ctx.fillText("xyz"[c - 1], left + plotW - 40 + c * 10, box.y + 12);
  }
}

function formatTick(value) {
  return Math.abs(value) >= 10 ? value.toFixed(0) : value.toPrecision(2);
}
