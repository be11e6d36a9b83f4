// Plots decimated LIDAR points top-down into an RGBA pixel buffer (runs in the LIDAR worker):
// one pass over the points, no path per point, coloured by height.

const Z_RANGE_M = [-3.5, 6.0]; // height colour scale in the LIDAR frame (mounted 3 m above water)

/**
 * The map's view as the page sends it, in device pixels: `{widthPx, heightPx, cxPx, cyPx,
 * pxPerM, mounts: {frame_id: [x_m, y_m]}}`. Vessel frame, bow (+x) up, port (+y) left.
 */
export class PointRaster {
  constructor() {
    this.pixels = new Uint32Array(0); // reused scan after scan: no 2 MB allocation per scan
  }

  /**
   * Plot `points : (k, 3) float32` of frame `frameId` for `view`; returns an ImageData over the
   * reused buffer (valid until the next call).
   */
  render(points, frameId, view) {
    const { widthPx, heightPx, cxPx, cyPx, pxPerM } = view;
    if (this.pixels.length !== widthPx * heightPx) this.pixels = new Uint32Array(widthPx * heightPx);
    const pixels = this.pixels;
    pixels.fill(0);
    const [dx, dy] = view.mounts?.[frameId] ?? [0, 0];
    const [zLow, zHigh] = Z_RANGE_M;
    for (let i = 0; i < points.length; i += 3) {
      const px = Math.round(cxPx - (points[i + 1] + dy) * pxPerM);
      const py = Math.round(cyPx - (points[i] + dx) * pxPerM);
      if (px < 0 || py < 0 || px >= widthPx - 1 || py >= heightPx - 1) continue;
      const level = Math.max(0, Math.min(255, ((points[i + 2] - zLow) / (zHigh - zLow)) * 255)) | 0;
      const colour = HEIGHT_PALETTE[level];
      const at = py * widthPx + px; // a 2 x 2 dot: single pixels vanish on a busy map
      pixels[at] = colour;
      pixels[at + 1] = colour;
      pixels[at + widthPx] = colour;
      pixels[at + widthPx + 1] = colour;
    }
    return new ImageData(new Uint8ClampedArray(pixels.buffer), widthPx, heightPx);
  }
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
