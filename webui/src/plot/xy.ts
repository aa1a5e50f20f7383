// xy.ts -- the x–y mode of a plot panel: one variable against another over the panel's window
// (e.g. a robot's world X against Y), drawn on a canvas, newest point marked.
import type { SampleRing } from "./ring";
import { niceTicks, tickLabel } from "./ticks";

const PAD = { left: 64, right: 12, top: 10, bottom: 34 };
const MAX_POINTS = 200_000; // beyond this many samples, every n-th is drawn

export class XYPlot {
  readonly canvas: HTMLCanvasElement;
  equal = true;

  constructor(host: HTMLElement) {
    this.canvas = document.createElement("canvas");
    this.canvas.dataset.testid = "xy-canvas";
    host.appendChild(this.canvas);
  }

  /** Draws channels cx against cy of the ring's logical samples [i0, i1); returns the points drawn. */
  draw(
    ring: SampleRing | null,
    i0: number,
    i1: number,
    cx: number,
    cy: number,
    xLabel: string,
    yLabel: string,
    width: number,
    height: number,
  ): number {
    const dpr = window.devicePixelRatio || 1;
    const c = this.canvas;
    if (c.width !== Math.round(width * dpr) || c.height !== Math.round(height * dpr)) {
      c.width = Math.round(width * dpr);
      c.height = Math.round(height * dpr);
      c.style.width = `${width}px`;
      c.style.height = `${height}px`;
    }
    const g = c.getContext("2d");
    if (!g) return 0;
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.clearRect(0, 0, width, height);
    g.font = "11px system-ui, sans-serif";
    g.fillStyle = "#5f6b76";
    if (!ring || cx < 0 || cy < 0 || i1 <= i0) {
      g.fillText(
        cx < 0 || cy < 0 ? "pick a variable for X and one for Y" : "waiting for samples…",
        PAD.left,
        PAD.top + 20,
      );
      return 0;
    }
    const X = ring.cols[cx];
    const Y = ring.cols[cy];
    const stride = Math.max(1, Math.ceil((i1 - i0) / MAX_POINTS));
    let xmin = Infinity,
      xmax = -Infinity,
      ymin = Infinity,
      ymax = -Infinity;
    for (let i = i0; i < i1; i += stride) {
      const p = ring.slot(i);
      const x = X[p],
        y = Y[p];
      if (Number.isNaN(x) || Number.isNaN(y)) continue;
      if (x < xmin) xmin = x;
      if (x > xmax) xmax = x;
      if (y < ymin) ymin = y;
      if (y > ymax) ymax = y;
    }
    if (xmin > xmax) {
      g.fillText("no values yet", PAD.left, PAD.top + 20);
      return 0;
    }
    const pw = width - PAD.left - PAD.right;
    const ph = height - PAD.top - PAD.bottom;
    // some room around the data; a flat signal still gets a range
    const padx = (xmax - xmin) * 0.05 || Math.abs(xmax) * 0.05 || 1;
    const pady = (ymax - ymin) * 0.05 || Math.abs(ymax) * 0.05 || 1;
    xmin -= padx;
    xmax += padx;
    ymin -= pady;
    ymax += pady;
    if (this.equal) {
      const sx = (xmax - xmin) / pw,
        sy = (ymax - ymin) / ph,
        s = Math.max(sx, sy);
      const cxm = (xmin + xmax) / 2,
        cym = (ymin + ymax) / 2;
      xmin = cxm - (s * pw) / 2;
      xmax = cxm + (s * pw) / 2;
      ymin = cym - (s * ph) / 2;
      ymax = cym + (s * ph) / 2;
    }
    const px = (v: number) => PAD.left + ((v - xmin) / (xmax - xmin)) * pw;
    const py = (v: number) => PAD.top + ph - ((v - ymin) / (ymax - ymin)) * ph;
    // grid and axes
    g.strokeStyle = "#e3e7eb";
    g.lineWidth = 1;
    g.beginPath();
    for (const t of niceTicks(xmin, xmax, Math.max(2, Math.floor(pw / 90)))) {
      const x = Math.round(px(t)) + 0.5;
      g.moveTo(x, PAD.top);
      g.lineTo(x, PAD.top + ph);
      g.fillText(tickLabel(t), x - 12, PAD.top + ph + 14);
    }
    for (const t of niceTicks(ymin, ymax, Math.max(2, Math.floor(ph / 50)))) {
      const y = Math.round(py(t)) + 0.5;
      g.moveTo(PAD.left, y);
      g.lineTo(PAD.left + pw, y);
      g.fillText(tickLabel(t), 4, y + 4);
    }
    g.stroke();
    g.strokeStyle = "#9aa5b1";
    g.strokeRect(PAD.left + 0.5, PAD.top + 0.5, pw, ph);
    g.fillStyle = "#1d232a";
    g.fillText(`X: ${xLabel}`, PAD.left, height - 4);
    g.fillText(`Y: ${yLabel}`, PAD.left + 4, PAD.top + 12);
    // the trajectory: consecutive points on the same pixel are drawn once
    g.save();
    g.beginPath();
    g.rect(PAD.left, PAD.top, pw, ph);
    g.clip();
    g.strokeStyle = "#0b63c5";
    g.lineWidth = 1.25;
    g.beginPath();
    let drawn = 0,
      lx = NaN,
      ly = NaN,
      pen = false;
    const dec = ring.decimation;
    for (let i = i0; i < i1; i += stride) {
      const p = ring.slot(i);
      const x = X[p],
        y = Y[p];
      if (Number.isNaN(x) || Number.isNaN(y)) {
        pen = false;
        continue;
      }
      if (pen && stride === 1 && i > i0 && ring.seq[p] - ring.seqAt(i - 1) !== dec) pen = false;
      const qx = Math.round(px(x) * 2) / 2,
        qy = Math.round(py(y) * 2) / 2;
      if (pen && qx === lx && qy === ly) continue;
      if (pen) g.lineTo(qx, qy);
      else g.moveTo(qx, qy);
      pen = true;
      lx = qx;
      ly = qy;
      drawn++;
    }
    g.stroke();
    const pl = ring.slot(i1 - 1);
    if (!Number.isNaN(X[pl]) && !Number.isNaN(Y[pl])) {
      g.fillStyle = "#c62828";
      g.beginPath();
      g.arc(px(X[pl]), py(Y[pl]), 4, 0, 2 * Math.PI);
      g.fill();
    }
    g.restore();
    return drawn;
  }
}
