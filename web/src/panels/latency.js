// Latency panel: per topic, capture → this page (measured here from header.stamp) and, from
// /riverbridge/trace, the stacked per-stage medians of the simulator → bridge → navigation path.
import { COLORS, drawWaiting, fitCanvas } from "../canvas.js";
import { STAGES } from "../trace.js";

const STAGE_COLORS = ["#8d6e63", "#ab47bc", "#7e57c2", "#5c6bc0", "#42a5f5", "#26c6da",
  "#26a69a", "#66bb6a", "#d4e157", "#ffca28"];
const REDRAW_MS = 500; // statistics are medians; twice a second is live enough

export class LatencyPanel {
  constructor(canvas, traceStats, arrivalAges) {
    this.canvas = canvas;
    this.trace = traceStats;
    this.ages = arrivalAges;
    this.lastDrawMs = -Infinity;
  }

  draw(nowMs) {
    const { ctx, width, height, resized } = fitCanvas(this.canvas);
    if (!resized && nowMs - this.lastDrawMs < REDRAW_MS) return;
    this.lastDrawMs = nowMs;
    ctx.fillStyle = COLORS.background;
    ctx.fillRect(0, 0, width, height);
    const rows = latencyRows(this.ages.medians(), this.trace.medians());
    if (rows.length === 0) {
      drawWaiting(ctx, width, height, "messages");
      return;
    }
    const scaleMs = niceMax(Math.max(1, ...rows.map(rowTotalMs)));
    const layout = { labelW: 170, textW: 150, top: 8, rowH: Math.min(24, (height - 58) / rows.length) };
    layout.barW = width - layout.labelW - layout.textW - 10;
    ctx.font = "11px system-ui, sans-serif";
    rows.forEach((row, i) => drawRow(ctx, row, layout.top + i * layout.rowH, layout, scaleMs));
    drawAxis(ctx, layout, scaleMs, layout.top + rows.length * layout.rowH + 4);
    drawLegend(ctx, usedStages(rows), width, height, this.trace.spansSeen);
  }
}

/** Topics with something to show, with their page ages and trace medians. */
function latencyRows(ages, stages) {
  const topics = [...new Set([...Object.keys(stages), ...Object.keys(ages)])].sort();
  return topics
    .map((topic) => ({ topic, age: ages[topic], stages: stages[topic] ?? {} }))
    .filter((row) => row.age >= 0 || STAGES.some((s) => row.stages[s] > 0));
}

function usedStages(rows) {
  return STAGES.filter((s) => rows.some((row) => row.stages[s] > 0));
}

function rowTotalMs(row) {
  const stageSum = STAGES.reduce((sum, s) => sum + (Math.max(0, row.stages[s]) || 0), 0);
  return Math.max(stageSum, row.stages.end_to_end || 0, row.age || 0);
}

/** Upper half: stacked stage medians; lower half: capture → this page; text at the right. */
function drawRow(ctx, row, y, { labelW, barW, rowH }, scaleMs) {
  const h = Math.max(6, rowH - 6);
  const pxPerMs = barW / scaleMs;
  ctx.fillStyle = COLORS.text;
  ctx.fillText(row.topic, 6, y + h - 1);
  let x = labelW;
  STAGES.forEach((stage, k) => {
    const ms = row.stages[stage];
    if (!(ms > 0)) return;
    ctx.fillStyle = STAGE_COLORS[k];
    ctx.fillRect(x, y, Math.max(1, ms * pxPerMs), h * 0.5);
    x += ms * pxPerMs;
  });
  if (row.age >= 0) {
    ctx.fillStyle = COLORS.accent;
    ctx.fillRect(labelW, y + h * 0.6, Math.max(1, row.age * pxPerMs), h * 0.4);
  }
  const e2e = row.stages.end_to_end;
  const parts = [];
  if (e2e >= 0) parts.push(`e2e ${formatMs(e2e)}`);
  else if (x > labelW) parts.push(`stages ${formatMs((x - labelW) / pxPerMs)}`);
  if (row.age >= 0) parts.push(`here ${formatMs(row.age)}`);
  ctx.fillStyle = COLORS.text;
  ctx.fillText(`${parts.join(" · ")} ms`, labelW + barW + 10, y + h - 1);
}

function drawAxis(ctx, { labelW, barW }, scaleMs, y) {
  ctx.strokeStyle = COLORS.axis;
  ctx.fillStyle = COLORS.text;
  ctx.beginPath();
  ctx.moveTo(labelW, y);
  ctx.lineTo(labelW + barW, y);
  ctx.stroke();
  for (let k = 0; k <= 4; k++) {
    const label = `${((scaleMs * k) / 4).toFixed(scaleMs < 8 ? 1 : 0)}${k === 4 ? " ms" : ""}`;
    const x = labelW + (barW * k) / 4;
    ctx.fillText(label, x - (k === 0 ? 0 : ctx.measureText(label).width / 2), y + 12);
  }
}

/** Colour keys of the stages in use, wrapped over as many lines as the width needs. */
function drawLegend(ctx, stages, width, height, spansSeen) {
  const items = [["capture → here", COLORS.accent], ...stages.map((s) => [s, STAGE_COLORS[STAGES.indexOf(s)]])];
  const lines = [[]];
  let used = 6;
  for (const item of items) {
    const w = ctx.measureText(item[0]).width + 20;
    if (used + w > width && lines.at(-1).length > 0) {
      lines.push([]);
      used = 6;
    }
    lines.at(-1).push([...item, used]);
    used += w;
  }
  lines.forEach((line, i) => {
    const y = height - 6 - (lines.length - 1 - i) * 14;
    for (const [label, color, x] of line) {
      ctx.fillStyle = color;
      ctx.fillRect(x, y - 8, 8, 8);
      ctx.fillStyle = COLORS.text;
      ctx.fillText(label, x + 11, y);
    }
  });
  if (spansSeen === 0) ctx.fillText("no /riverbridge/trace spans yet", 6, height - 8 - lines.length * 14);
}

function formatMs(ms) {
  return ms < 10 ? ms.toFixed(1) : ms.toFixed(0);
}

function niceMax(value) {
  const power = 10 ** Math.floor(Math.log10(value));
  for (const unit of [1, 2, 5, 10]) if (unit * power >= value) return unit * power;
  return 10 * power;
}
