// Top-down map around the vessel (thesis figures 16, 19, 21 as one live picture): LIDAR points
// coloured by height, LIDAR cluster boxes, radar CFAR detections and the fused obstacle grid.
// Vessel frame, bow up; sensor mounts come from /tf_static. Layers are rebuilt only when their
// message arrives; a frame just composites them.
import { COLORS, drawWaiting, fitCanvas } from "../canvas.js";
import { decimateCloud } from "../pointcloud.js";
import { bytesOf } from "../rosmsg.js";

const MAX_POINTS = 40000; // drawn per scan; a full scan is ~180k, more adds no visible detail
const Z_RANGE_M = [-3.5, 6.0]; // height colour scale in the LIDAR frame (mounted 3 m above water)
const VESSEL_LENGTH_M = 7.0; // simulator VesselConfig.length_m
const VESSEL_BEAM_M = 2.5; // simulator VesselConfig.beam_m

export class MapPanel {
  constructor(canvas) {
    this.canvas = canvas;
    this.halfRangeM = 60;
    this.mounts = new Map(); // frame_id -> [x_m, y_m] in base_link
    this.points = null; // (k, 3) float32, vessel frame
    this.boxes = [];
    this.detections = [];
    this.grid = null; // {image: canvas, pixels: ImageData, resolution, origin: [x_m, y_m]}
    this.pointsLayer = document.createElement("canvas");
    this.pointsImage = null; // ImageData reused scan after scan (no 2 MB allocation per scan)
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
  }

  #offset(frameId) {
    return this.mounts.get(frameId) ?? [0, 0];
  }

  onCloud(cloud) {
    const points = decimateCloud(cloud, bytesOf(cloud.data), MAX_POINTS);
    const [dx, dy] = this.#offset(cloud.header.frame_id);
    for (let i = 0; i < points.length; i += 3) {
      points[i] += dx;
      points[i + 1] += dy;
    }
    this.points = points;
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
    if (this.rasterStale || resized) {
      this.#drawRaster(view, width, height, ratio);
      this.rasterStale = false;
    }
    ctx.drawImage(this.raster, 0, 0, width, height);
    this.#drawBoxes(ctx, view);
    this.#drawDetections(ctx, view);
    this.#drawVessel(ctx, view);
    this.#drawLegend(ctx, width, height);
    if (!this.points && !this.grid) drawWaiting(ctx, width, height * 0.3, "/lidar/points");
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
    if (this.points) {
      this.pointsImage = renderPoints(this.pointsLayer, this.pointsImage, this.points, view,
        pixelWidth, pixelHeight, ratio);
      ctx.drawImage(this.pointsLayer, 0, 0, width, height);
    }
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
      ["obstacle grid", `rgb(${COLORS.occupied.join(",")})`]];
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
    const counts = `${this.points ? this.points.length / 3 : 0} pts · ${this.boxes.length} boxes · ${this.detections.length} radar`;
    ctx.fillText(counts, width - ctx.measureText(counts).width - 10, 16);
  }
}

/**
 * Plot `points : (k, 3)` into `layer` pixel by pixel (one putImageData, no path per point).
 * Reuses `image` when its size still fits; returns the ImageData used.
 */
function renderPoints(layer, image, points, { cx, cy, scale }, pixelWidth, pixelHeight, ratio) {
  if (layer.width !== pixelWidth || layer.height !== pixelHeight) {
    Object.assign(layer, { width: pixelWidth, height: pixelHeight });
  }
  const ctx = layer.getContext("2d");
  if (image?.width !== pixelWidth || image?.height !== pixelHeight) {
    image = ctx.createImageData(pixelWidth, pixelHeight);
  }
  const pixels = new Uint32Array(image.data.buffer);
  pixels.fill(0);
  const palette = HEIGHT_PALETTE;
  const [zLow, zHigh] = Z_RANGE_M;
  const s = scale * ratio;
  for (let i = 0; i < points.length; i += 3) {
    const px = Math.round(cx * ratio - points[i + 1] * s);
    const py = Math.round(cy * ratio - points[i] * s);
    if (px < 0 || py < 0 || px >= pixelWidth - 1 || py >= pixelHeight - 1) continue;
    const level = Math.max(0, Math.min(255, ((points[i + 2] - zLow) / (zHigh - zLow)) * 255)) | 0;
    const colour = palette[level];
    const at = py * pixelWidth + px; // a 2 x 2 dot: single pixels vanish on a busy map
    pixels[at] = colour;
    pixels[at + 1] = colour;
    pixels[at + pixelWidth] = colour;
    pixels[at + pixelWidth + 1] = colour;
  }
  ctx.putImageData(image, 0, 0);
  return image;
}

/**
 * 256 ABGR words by height: water returns (bottom ~8 %) a dim blue that stays in the
 * background, then green through yellow for banks, vegetation and obstacles.
 */
function heightPalette() {
  const palette = new Uint32Array(256);
  const waterTop = 20;
  for (let i = 0; i < 256; i++) {
    const t = Math.max(0, (i - waterTop) / (255 - waterTop));
    let [r, g, b] = [40 + 120 * t + 95 * t * t, 150 + 105 * t, 90 * (1 - t)];
    if (i < waterTop) [r, g, b] = [24, 52, 88];
    palette[i] = (255 << 24) | (Math.round(b) << 16) | (Math.round(g) << 8) | Math.round(r);
  }
  return palette;
}

const HEIGHT_PALETTE = heightPalette();

function niceStep(raw) {
  const power = 10 ** Math.floor(Math.log10(raw));
  const unit = raw / power;
  return (unit < 2 ? 1 : unit < 5 ? 2 : 5) * power;
}
