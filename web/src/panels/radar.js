// Radar plan-position indicator: the polar reflectance image of /radar/image
// (riverbridge_msgs/msg/RadarImage, one row per beam, one column per range cell) drawn around
// the sensor, bow up, with the CFAR detections of /nav/radar_detections on top.
// Each sweep is painted through a pixel -> cell lookup table built once per geometry, so a new
// image costs one pass over a small square raster, not one path per cell.
import { beginPanelFrame, COLORS } from "../canvas.js";
import { topic } from "../catalogue.js";
import { stampMs } from "../rosmsg.js";

const RASTER_PX = 256; // side of the polar -> Cartesian raster, scaled up when drawn

export class RadarPanel {
  constructor(canvas) {
    this.canvas = canvas;
    this.raster = Object.assign(document.createElement("canvas"), { width: RASTER_PX, height: RASTER_PX });
    this.pixels = this.raster.getContext("2d").createImageData(RASTER_PX, RASTER_PX);
    this.lookup = null; // {key, cells: Int32Array(RASTER_PX²) of flat (beam, cell) index or -1}
    this.sweep = null; // {rangeMaxM, numBeams, numCells, peak, stampMs}
    this.detections = []; // [range_m, azimuth_rad]
    this.sweeps = 0;
    this.dirty = true;
  }

  onImage(message) {
    const geometry = radarGeometry(message);
    const reflectance = floatsOf(message.reflectance);
    if (reflectance.length < geometry.numBeams * geometry.numCells) return;
    if (this.lookup?.key !== geometry.key) this.lookup = { key: geometry.key, cells: cellLookup(geometry) };
    const peak = paintSweep(this.pixels, this.lookup.cells, reflectance);
    this.raster.getContext("2d").putImageData(this.pixels, 0, 0);
    this.sweep = { ...geometry, peak, stampMs: stampMs(message.header) };
    this.sweeps += 1;
    this.dirty = true;
  }

  onDetections(message) {
    this.detections = (message.detections ?? []).map((d) => [d.range_m, d.azimuth_rad]);
    this.dirty = true;
  }

  draw() {
    const frame = beginPanelFrame(this, topic("radar").name, Boolean(this.sweep));
    if (!frame) return;
    const { ctx, width, height } = frame;
    const radiusPx = Math.max(10, Math.min(width, height) / 2 - 14);
    const view = { cx: width / 2, cy: height / 2 + 6, scale: radiusPx / this.sweep.rangeMaxM };
    ctx.imageSmoothingEnabled = true;
    ctx.drawImage(this.raster, view.cx - radiusPx, view.cy - radiusPx, 2 * radiusPx, 2 * radiusPx);
    drawRings(ctx, view, this.sweep.rangeMaxM);
    this.#drawDetections(ctx, view);
    this.#drawCaption(ctx, width);
  }

  /** Small dots, not outlines: CFAR can flag hundreds of cells and the echoes must stay visible. */
  #drawDetections(ctx, { cx, cy, scale }) {
    ctx.fillStyle = COLORS.radar;
    ctx.globalAlpha = 0.85;
    ctx.beginPath();
    for (const [rangeM, azimuthRad] of this.detections) {
      // bow up: sensor +x is screen up, +y (port) is screen left
      const x = cx - rangeM * Math.sin(azimuthRad) * scale;
      const y = cy - rangeM * Math.cos(azimuthRad) * scale;
      ctx.rect(x - 1.5, y - 1.5, 3, 3);
    }
    ctx.fill();
    ctx.globalAlpha = 1;
  }

  /** Geometry and peak top left; detection count and the sweep's capture time (UTC) top right. */
  #drawCaption(ctx, width) {
    const { numBeams, numCells, peak, stampMs: stamp } = this.sweep;
    ctx.fillStyle = COLORS.text;
    ctx.font = "11px system-ui, sans-serif";
    ctx.fillText(`${numBeams} × ${numCells} cells`, 8, 14);
    ctx.fillText(`peak ${peak.toFixed(1)}`, 8, 28);
    for (const [line, y] of [[`${this.detections.length} detections`, 14],
      [new Date(stamp).toISOString().slice(11, 22), 28]]) {
      ctx.fillText(line, width - ctx.measureText(line).width - 8, y);
    }
  }
}

/** The image's polar geometry, with a key that changes whenever the lookup table must. */
function radarGeometry(message) {
  const numBeams = Number(message.num_beams);
  const numCells = Number(message.num_cells);
  const azimuthMinRad = Number(message.azimuth_min_rad);
  const azimuthStepRad = Number(message.azimuth_step_rad) || (2 * Math.PI) / Math.max(1, numBeams);
  const rangeMinM = Number(message.range_min_m);
  const rangeStepM = Number(message.range_step_m) || 1;
  const rangeMaxM = rangeMinM + numCells * rangeStepM;
  const key = [numBeams, numCells, azimuthMinRad, azimuthStepRad, rangeMinM, rangeStepM].join();
  return { key, numBeams, numCells, azimuthMinRad, azimuthStepRad, rangeMinM, rangeStepM, rangeMaxM };
}

/**
 * For every raster pixel, the flat index beam * numCells + cell it shows, or -1 outside the
 * image. The raster spans ±rangeMaxM around the sensor, bow (+x) up and port (+y) left.
 */
function cellLookup(g) {
  const cells = new Int32Array(RASTER_PX * RASTER_PX);
  const half = RASTER_PX / 2;
  const metresPerPx = g.rangeMaxM / half;
  for (let v = 0; v < RASTER_PX; v++) {
    for (let u = 0; u < RASTER_PX; u++) {
      const x = (half - v - 0.5) * metresPerPx;
      const y = (half - u - 0.5) * metresPerPx;
      const cell = Math.floor((Math.hypot(x, y) - g.rangeMinM) / g.rangeStepM);
      // beam k is centred on azimuthMin + k·step, so the nearest centre owns the pixel
      const turns = Math.round((Math.atan2(y, x) - g.azimuthMinRad) / g.azimuthStepRad);
      const beam = ((turns % g.numBeams) + g.numBeams) % g.numBeams;
      cells[v * RASTER_PX + u] = cell >= 0 && cell < g.numCells ? beam * g.numCells + cell : -1;
    }
  }
  return cells;
}

/**
 * Colour `pixels` from `reflectance` through `cells`, on a log scale up to the sweep's peak
 * (reflectance sums span orders of magnitude between water and a quay wall). Returns the peak.
 */
function paintSweep(pixels, cells, reflectance) {
  let peak = 0;
  for (let i = 0; i < reflectance.length; i++) if (reflectance[i] > peak) peak = reflectance[i];
  const words = new Uint32Array(pixels.data.buffer);
  const toLevel = 255 / Math.log1p(Math.max(peak, 1e-6));
  for (let i = 0; i < cells.length; i++) {
    const cell = cells[i];
    if (cell < 0) {
      words[i] = 0;
      continue;
    }
    const value = reflectance[cell];
    words[i] = PALETTE[value > 0 ? Math.min(255, (Math.log1p(value) * toLevel) | 0) : 0];
  }
  return peak;
}

function drawRings(ctx, { cx, cy, scale }, rangeMaxM) {
  ctx.strokeStyle = COLORS.axis;
  ctx.fillStyle = COLORS.text;
  ctx.font = "10px system-ui, sans-serif";
  ctx.lineWidth = 1;
  const step = rangeMaxM > 60 ? 25 : 10;
  for (let r = step; r <= rangeMaxM + 1e-6; r += step) {
    ctx.beginPath();
    ctx.arc(cx, cy, r * scale, 0, 2 * Math.PI);
    ctx.stroke();
    ctx.fillText(`${r} m`, cx + 3, cy - r * scale + 11);
  }
  ctx.beginPath(); // heading line: the bow
  ctx.moveTo(cx, cy);
  ctx.lineTo(cx, cy - rangeMaxM * scale);
  ctx.stroke();
}

/** A float32[] field: Float32Array from CBOR, a plain array from JSON. */
function floatsOf(value) {
  if (value instanceof Float32Array || value instanceof Float64Array) return value;
  return Float32Array.from(value ?? []);
}

/** 256 ABGR words: empty cells a dark green-blue, echoes through green to amber. */
function radarPalette() {
  const palette = new Uint32Array(256);
  for (let i = 0; i < 256; i++) {
    const t = i / 255;
    const [r, g, b] = [30 + 225 * t * t, 45 + 200 * Math.sqrt(t), 40 + 30 * (1 - t)];
    palette[i] = (255 << 24) | (Math.round(b) << 16) | (Math.round(g) << 8) | Math.round(r);
  }
  return palette;
}

const PALETTE = radarPalette();
