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

/** Draws every shown series as one polyline, lifting the pen at nulls: what uPlot's own path
 * builder would do, without its per-point work (the points are already decimated). */
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
    const ys = u.data[s] as (number | null)[];
    g.strokeStyle = COLORS[(s - 1) % COLORS.length];
    g.beginPath();
    let pen = false;
    for (let i = 0; i < xs.length; i++) {
      const v = ys[i];
      if (v == null) {
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
