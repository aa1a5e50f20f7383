// lines.ts -- the series of a time plot, drawn straight onto uPlot's canvas from points that are
// already decimated (at most one a pixel), and the series' colours.
import uPlot from "uplot";

export const COLORS = [
  "#1f77b4",
  "#d62728",
  "#2ca02c",
  "#ff7f0e",
  "#9467bd",
  "#8c564b",
  "#e377c2",
  "#17becf",
  "#7f7f7f",
  "#bcbd22",
  "#393b79",
  "#ad494a",
  "#637939",
  "#8c6d31",
  "#7b4173",
  "#3182bd",
];

/** Draws every shown series as one polyline, lifting the pen at nulls and drawing across
 * undefined (no sample of this series there): what uPlot's own path builder would do, without its
 * per-point work (the points are already decimated). */
export function drawLines(u: uPlot): void {
  const g = u.ctx;
  const { left, top, width, height } = u.bbox;
  const xs = u.data[0];
  const sx = u.scales.x;
  const sy = u.scales.y;
  if (sx.min == null || sx.max == null || sy.min == null || sy.max == null || sx.max <= sx.min || sy.max <= sy.min)
    return;
  const ax = width / (sx.max - sx.min);
  const ay = height / (sy.max - sy.min);
  const x0 = sx.min;
  const y0 = sy.min;
  const bottom = top + height;
  g.save();
  g.beginPath();
  g.rect(left, top, width, height);
  g.clip();
  g.lineWidth = uPlot.pxRatio;
  g.lineJoin = "round";
  for (let s = 1; s < u.series.length; s++) {
    const ser = u.series[s];
    if (!ser.show) continue;
    const ys = u.data[s] as (number | null | undefined)[];
    g.strokeStyle = COLORS[(s - 1) % COLORS.length];
    g.beginPath();
    let pen = false;
    for (let i = 0; i < xs.length; i++) {
      const v = ys[i];
      if (v === undefined) continue;
      if (v === null) {
        pen = false;
        continue;
      }
      const px = left + (xs[i] - x0) * ax;
      const py = bottom - (v - y0) * ay;
      if (pen) g.lineTo(px, py);
      else {
        g.moveTo(px, py);
        pen = true;
      }
    }
    g.stroke();
  }
  g.restore();
}

/** Vertical dashed lines across the plot at x values (a shot's trigger), each with its label. */
export function drawMarks(u: uPlot, marks: readonly { x: number; label: string }[]): void {
  const sx = u.scales.x;
  if (!marks.length || sx.min == null || sx.max == null || sx.max <= sx.min) return;
  const g = u.ctx;
  const { left, top, width, height } = u.bbox;
  const r = uPlot.pxRatio;
  g.save();
  g.strokeStyle = "#b3261e";
  g.fillStyle = "#b3261e";
  g.lineWidth = r;
  g.setLineDash([4 * r, 3 * r]);
  g.font = `${11 * r}px system-ui, sans-serif`;
  for (const m of marks) {
    if (m.x < sx.min || m.x > sx.max) continue;
    const px = Math.round(left + ((m.x - sx.min) / (sx.max - sx.min)) * width) + 0.5;
    g.beginPath();
    g.moveTo(px, top);
    g.lineTo(px, top + height);
    g.stroke();
    g.fillText(m.label, px + 3 * r, top + 12 * r);
  }
  g.restore();
}
