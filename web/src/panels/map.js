// Top-down map around the vessel (thesis figures 16, 19, 21 as one live picture): LIDAR points
// coloured by height, LIDAR cluster boxes, radar CFAR detections and the fused obstacle grid,
// and the autopilot's route (/guidance/path, map frame, turned into the vessel frame by /odom).
// Vessel frame, bow up; sensor mounts come from /tf_static. Layers are rebuilt only when their
// message arrives; a frame just composites them. The LIDAR layer arrives as a finished bitmap
// from the LIDAR worker, which is told the view (`onView`) whenever it changes.
import { COLORS, drawWaiting, fitCanvas } from "../canvas.js";
import { topic } from "../catalogue.js";

const VESSEL_LENGTH_M = 7.0; // simulator VesselConfig.length_m
const VESSEL_BEAM_M = 2.5; // simulator VesselConfig.beam_m

export class MapPanel {
  constructor(canvas) {
    this.canvas = canvas;
    this.halfRangeM = 60;
    this.mounts = new Map(); // frame_id -> [x_m, y_m] in base_link
    this.pointsBitmap = null; // the LIDAR worker's plot of the latest scan, device pixels
    this.pointCount = 0;
    this.onView = null; // (view) => void: where the map's view goes when it changes
    this.viewKey = ""; // the view last sent to the worker, as JSON
    this.boxes = [];
    this.detections = [];
    this.grid = null; // {image: canvas, pixels: ImageData, resolution, origin: [x_m, y_m]}
    this.path = []; // the autopilot's route, [x_m, y_m] in the map frame
    this.pose = null; // the vessel's {xM, yM, yawRad} in the map frame
    this.raster = document.createElement("canvas"); // background, rings, grid and points
    this.rasterStale = true;
    this.dirty = true;
    canvas.addEventListener("wheel", (event) => {
      event.preventDefault();
      this.halfRangeM = Math.min(400, Math.max(10, this.halfRangeM * Math.exp(event.deltaY / 500)));
      this.rasterStale = true;
      this.dirty = true;
    }, { passive: false });
  }

  onStaticTf(message) {
    for (const t of message.transforms ?? []) {
      const v = t.transform.translation;
      this.mounts.set(t.child_frame_id, [v.x, v.y]);
    }
    this.viewKey = ""; // the worker offsets the points by these mounts: resend the view
    this.dirty = true;
  }

  #offset(frameId) {
    return this.mounts.get(frameId) ?? [0, 0];
  }

  /** A scan plotted by the LIDAR worker: `bitmap` covers the canvas in device pixels. */
  onPointsImage(bitmap, pointCount) {
    this.pointsBitmap?.close();
    this.pointsBitmap = bitmap;
    this.pointCount = pointCount;
    this.rasterStale = true;
    this.dirty = true;
  }

  onBoxes(message) {
    const [dx, dy] = this.#offset(message.header.frame_id);
    this.boxes = (message.boxes ?? []).map((b) => [b.min.x + dx, b.min.y + dy, b.max.x + dx, b.max.y + dy]);
    this.dirty = true;
  }

  onDetections(message) {
    const [dx, dy] = this.#offset(message.header.frame_id);
    this.detections = (message.detections ?? []).map((d) => [d.x_m + dx, d.y_m + dy]);
    this.dirty = true;
  }

  onPath(message) {
    this.path = (message.poses ?? []).map((p) => [p.pose.position.x, p.pose.position.y]);
    this.dirty = true;
  }

  onPose({ xM, yM, yawRad }) {
    this.pose = { xM, yM, yawRad };
    if (this.path.length) this.dirty = true; // the route moves under the vessel
  }

  onGrid(message) {
    const { width, height, resolution, origin } = message.info;
    let image = this.grid?.image;
    if (image?.width !== width || image?.height !== height) {
      image = Object.assign(document.createElement("canvas"), { width, height });
    }
    const ctx = image.getContext("2d");
    const pixels = this.grid?.pixels?.width === width && this.grid.pixels.height === height
      ? this.grid.pixels : ctx.createImageData(width, height);
    const words = new Uint32Array(pixels.data.buffer);
    const cells = message.data;
    const [r, g, b] = COLORS.occupied;
    for (let i = 0; i < width * height; i++) {
      const value = cells[i];
      // free or unknown cells stay transparent; occupied ones get more opaque with certainty
      words[i] = value <= 0 ? 0 : ((60 + Math.min(100, value) * 1.3) << 24) | (b << 16) | (g << 8) | r;
    }
    ctx.putImageData(pixels, 0, 0);
    this.grid = { image, pixels, resolution, origin: [origin.position.x, origin.position.y] };
    this.rasterStale = true;
    this.dirty = true;
  }

  /** Redraw if anything changed since the last frame; rasters only when theirs changed. */
  draw() {
    const { ctx, width, height, ratio, resized } = fitCanvas(this.canvas);
    if (!this.dirty && !resized) return;
    this.dirty = false;
    const view = { cx: width / 2, cy: height * 0.55, scale: Math.min(width, height) / (2 * this.halfRangeM) };
    this.#publishView(view, width, height, ratio);
    if (this.rasterStale || resized) {
      this.#drawRaster(view, width, height, ratio);
      this.rasterStale = false;
    }
    ctx.drawImage(this.raster, 0, 0, width, height);
    this.#drawPath(ctx, view);
    this.#drawBoxes(ctx, view);
    this.#drawDetections(ctx, view);
    this.#drawVessel(ctx, view);
    this.#drawLegend(ctx, width, height);
    if (!this.pointsBitmap && !this.grid) drawWaiting(ctx, width, height * 0.3, topic("lidar").name);
  }

  /** Tell the LIDAR worker the view in device pixels, when it differs from the last one sent. */
  #publishView({ cx, cy, scale }, width, height, ratio) {
    const view = {
      widthPx: Math.floor(width * ratio), heightPx: Math.floor(height * ratio),
      cxPx: cx * ratio, cyPx: cy * ratio,
      pxPerM: scale * ratio, mounts: Object.fromEntries(this.mounts),
    };
    const key = JSON.stringify(view);
    if (key === this.viewKey || !this.onView) return;
    this.viewKey = key;
    this.onView(view);
  }

  /** Background, range rings, obstacle grid and LIDAR points, in device pixels. */
  #drawRaster(view, width, height, ratio) {
    const [pixelWidth, pixelHeight] = [Math.floor(width * ratio), Math.floor(height * ratio)];
    if (this.raster.width !== pixelWidth || this.raster.height !== pixelHeight) {
      Object.assign(this.raster, { width: pixelWidth, height: pixelHeight });
    }
    const ctx = this.raster.getContext("2d");
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.fillStyle = COLORS.background;
    ctx.fillRect(0, 0, width, height);
    this.#drawRings(ctx, view);
    this.#drawGrid(ctx, view);
    if (this.pointsBitmap) ctx.drawImage(this.pointsBitmap, 0, 0, width, height);
  }

  #drawRings(ctx, { cx, cy, scale }) {
    ctx.strokeStyle = COLORS.grid;
    ctx.fillStyle = COLORS.text;
    ctx.font = "11px system-ui, sans-serif";
    ctx.lineWidth = 1;
    const step = niceStep(this.halfRangeM / 3);
    for (let r = step; r <= this.halfRangeM * 1.6; r += step) {
      ctx.beginPath();
      ctx.arc(cx, cy, r * scale, 0, 2 * Math.PI);
      ctx.stroke();
      ctx.fillText(`${r} m`, cx + 3, cy - r * scale - 3);
    }
  }

  #drawGrid(ctx, { cx, cy, scale }) {
    if (!this.grid) return;
    const { image, resolution, origin } = this.grid;
    const s = resolution * scale;
    ctx.save();
    ctx.imageSmoothingEnabled = false;
    // image pixel (u, v) = cell at vessel (ox + u·res, oy + v·res); screen up = +x, left = +y
    ctx.transform(0, -s, -s, 0, cx - origin[1] * scale, cy - origin[0] * scale);
    ctx.drawImage(image, 0, 0);
    ctx.restore();
  }

  /** The route in the vessel frame: map point minus the vessel's position, turned by -yaw. */
  #drawPath(ctx, { cx, cy, scale }) {
    if (this.path.length < 2 || !this.pose || !Number.isFinite(this.pose.yawRad)) return;
    const { xM, yM, yawRad } = this.pose;
    const [c, s] = [Math.cos(yawRad), Math.sin(yawRad)];
    ctx.strokeStyle = COLORS.path;
    ctx.lineWidth = 2;
    ctx.setLineDash([6, 4]);
    ctx.beginPath();
    this.path.forEach(([x, y], i) => {
      const [dx, dy] = [x - xM, y - yM];
      const [ahead, left] = [c * dx + s * dy, -s * dx + c * dy];
      const [u, v] = [cx - left * scale, cy - ahead * scale];
      if (i === 0) ctx.moveTo(u, v);
      else ctx.lineTo(u, v);
    });
    ctx.stroke();
    ctx.setLineDash([]);
  }

  #drawBoxes(ctx, { cx, cy, scale }) {
    ctx.strokeStyle = COLORS.box;
    ctx.lineWidth = 1.5;
    for (const [x0, y0, x1, y1] of this.boxes) {
      ctx.strokeRect(cx - y1 * scale, cy - x1 * scale, (y1 - y0) * scale, (x1 - x0) * scale);
    }
  }

  #drawDetections(ctx, { cx, cy, scale }) {
    ctx.fillStyle = COLORS.radar;
    ctx.globalAlpha = 0.8;
    ctx.beginPath();
    for (const [x, y] of this.detections) {
      ctx.rect(cx - y * scale - 1, cy - x * scale - 1, 2.5, 2.5);
    }
    ctx.fill();
    ctx.globalAlpha = 1;
  }

  #drawVessel(ctx, { cx, cy, scale }) {
    const half = Math.max(VESSEL_LENGTH_M * scale, 10) / 2;
    const beam = Math.max(VESSEL_BEAM_M * scale, 4) / 2;
    ctx.fillStyle = COLORS.vessel;
    ctx.beginPath();
    ctx.moveTo(cx, cy - half);
    ctx.lineTo(cx + beam, cy - half * 0.4);
    ctx.lineTo(cx + beam, cy + half);
    ctx.lineTo(cx - beam, cy + half);
    ctx.lineTo(cx - beam, cy - half * 0.4);
    ctx.closePath();
    ctx.fill();
  }

  #drawLegend(ctx, width, height) {
    const items = [["LIDAR (by height)", "#b4e05a"], ["water returns", "#183458"], ["boxes", COLORS.box], ["radar", COLORS.radar],
      ["obstacle grid", `rgb(${COLORS.occupied.join(",")})`], ["route", COLORS.path]];
    ctx.font = "11px system-ui, sans-serif";
    let x = 10;
    const y = height - 10;
    for (const [label, color] of items) {
      ctx.fillStyle = color;
      ctx.fillRect(x, y - 8, 10, 8);
      ctx.fillStyle = COLORS.text;
      ctx.fillText(label, x + 14, y);
      x += ctx.measureText(label).width + 30;
    }
    const counts = `${this.pointCount} pts · ${this.boxes.length} boxes · ${this.detections.length} radar`;
    ctx.fillText(counts, width - ctx.measureText(counts).width - 10, 16);
  }
}

function niceStep(raw) {
  const power = 10 ** Math.floor(Math.log10(raw));
  const unit = raw / power;
  return (unit < 2 ? 1 : unit < 5 ? 2 : 5) * power;
}
