// Canvas sizing for crisp drawing at any devicePixelRatio; drawing code works in CSS pixels.

// CSS sizes of the canvases, kept by a ResizeObserver: reading clientWidth every frame would
// force a synchronous layout whenever some text on the page changed since the last one.
const cssSizes = new WeakMap();
const resizeObserver = new ResizeObserver((entries) => {
  for (const entry of entries) {
    cssSizes.set(entry.target, { width: entry.contentRect.width, height: entry.contentRect.height });
  }
});

function cssSize(canvas) {
  let size = cssSizes.get(canvas);
  if (!size) {
    size = { width: canvas.clientWidth, height: canvas.clientHeight };
    cssSizes.set(canvas, size);
    resizeObserver.observe(canvas);
  }
  return size;
}

/**
 * Match the backing store to the element's size. Returns {ctx, width, height, resized}, with
 * `ctx` scaled so that one unit is one CSS pixel.
 */
export function fitCanvas(canvas) {
  const ratio = window.devicePixelRatio || 1;
  const size = cssSize(canvas);
  const width = Math.max(1, Math.floor(size.width));
  const height = Math.max(1, Math.floor(size.height));
  const resized = canvas.width !== Math.floor(width * ratio) ||
    canvas.height !== Math.floor(height * ratio);
  if (resized) {
    canvas.width = Math.floor(width * ratio);
    canvas.height = Math.floor(height * ratio);
  }
  const ctx = canvas.getContext("2d");
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  return { ctx, width, height, ratio, resized };
}

/**
 * Begin a panel's frame: null when the panel is unchanged (`panel.dirty` false) and its canvas
 * kept its size. Otherwise clears `panel.dirty` and the canvas; while `ready` is false it says
 * it is waiting for `topic` and returns null too. Returns fitCanvas's {ctx, width, height}.
 */
export function beginPanelFrame(panel, topic, ready) {
  const frame = fitCanvas(panel.canvas);
  if (!panel.dirty && !frame.resized) return null;
  panel.dirty = false;
  frame.ctx.fillStyle = COLORS.background;
  frame.ctx.fillRect(0, 0, frame.width, frame.height);
  if (!ready) {
    drawWaiting(frame.ctx, frame.width, frame.height, topic);
    return null;
  }
  return frame;
}

export const COLORS = {
  background: "#0b1116",
  grid: "#1f2a33",
  text: "#9fb0bd",
  axis: "#33424f",
  accent: "#4fc3f7",
  box: "#ffb74d",
  radar: "#ff5252",
  occupied: [239, 83, 80],
  path: "#7fdbff", // the autopilot's route
  vessel: "#e0f7fa",
  series: ["#ef5350", "#66bb6a", "#42a5f5"],
};

/** "No data yet" centred in a panel, so an empty panel explains itself. */
export function drawWaiting(ctx, width, height, what) {
  ctx.fillStyle = COLORS.text;
  ctx.font = "13px system-ui, sans-serif";
  ctx.textAlign = "center";
  ctx.fillText(`waiting for ${what}…`, width / 2, height / 2);
  ctx.textAlign = "left";
}
