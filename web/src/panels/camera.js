// Camera image with the extracted lines drawn over it (thesis figure 20). JPEGs are decoded by
// the browser off the main thread (createImageBitmap); the previous bitmap is freed at once.
import { beginPanelFrame, COLORS } from "../canvas.js";
import { topic } from "../catalogue.js";
import { bytesOf } from "../rosmsg.js";

export class CameraPanel {
  constructor(canvas) {
    this.canvas = canvas;
    this.bitmap = null;
    this.decoding = false;
    this.lines = null; // {width, height, segments: [[x1, y1, x2, y2]], probabilistic}
    this.dirty = true;
  }

  onImage(message) {
    if (this.decoding) return; // the next frame comes soon; never queue decodes
    this.decoding = true;
    const blob = new Blob([bytesOf(message.data)], { type: `image/${message.format || "jpeg"}` });
    createImageBitmap(blob)
      .then((bitmap) => {
        this.bitmap?.close();
        this.bitmap = bitmap;
        this.dirty = true;
      })
      .catch(() => {})
      .finally(() => {
        this.decoding = false;
      });
  }

  onLines(message) {
    this.lines = {
      width: message.image_width,
      height: message.image_height,
      segments: (message.lines ?? []).map((l) => lineSegment(l, message.image_width, message.image_height)),
    };
    this.dirty = true;
  }

  draw() {
    const frame = beginPanelFrame(this, topic("camera").name, Boolean(this.bitmap));
    if (!frame) return;
    const { ctx, width, height } = frame;
    const scale = Math.min(width / this.bitmap.width, height / this.bitmap.height);
    const [w, h] = [this.bitmap.width * scale, this.bitmap.height * scale];
    const [x0, y0] = [(width - w) / 2, (height - h) / 2];
    ctx.drawImage(this.bitmap, x0, y0, w, h);
    if (!this.lines) return;
    const sx = w / (this.lines.width || this.bitmap.width);
    const sy = h / (this.lines.height || this.bitmap.height);
    ctx.strokeStyle = COLORS.accent;
    ctx.lineWidth = 2;
    ctx.beginPath();
    for (const [x1, y1, x2, y2] of this.lines.segments) {
      ctx.moveTo(x0 + x1 * sx, y0 + y1 * sy);
      ctx.lineTo(x0 + x2 * sx, y0 + y2 * sy);
    }
    ctx.stroke();
    ctx.fillStyle = "rgba(0,0,0,0.55)";
    ctx.fillRect(x0 + 6, y0 + 6, 90, 18);
    ctx.fillStyle = COLORS.accent;
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(`${this.lines.segments.length} lines`, x0 + 12, y0 + 19);
  }
}

/**
 * A line as an image segment: the probabilistic Hough transform gives end points; the standard
 * one gives only (rho, theta), drawn across the whole image.
 */
function lineSegment(line, width, height) {
  if (line.x1_px !== line.x2_px || line.y1_px !== line.y2_px) {
    return [line.x1_px, line.y1_px, line.x2_px, line.y2_px];
  }
  const [c, s] = [Math.cos(line.theta_rad), Math.sin(line.theta_rad)];
  const [x, y] = [c * line.rho_px, s * line.rho_px];
  const reach = width + height;
  return [x - reach * s, y + reach * c, x + reach * s, y - reach * c];
}
