// histchart.ts -- one timing histogram on a canvas: x on a symmetric log scale in µs (jitter is
// signed), count on a log scale; bars since start (light) with the last poll interval over them
// (dark), and p50/p99/max marked.
import { type Bin, symlog } from "./hist";

export interface Mark {
  label: string;
  ns: number | null;
  color: string;
}

const PAD = { left: 40, right: 8, top: 14, bottom: 22 };

function decadeLabel(ns: number): string {
  const a = Math.abs(ns);
  const s = ns < 0 ? "−" : "";
  if (a === 0) return "0";
  if (a < 1e3) return `${s}${a} ns`;
  if (a < 1e6) return `${s}${a / 1e3} µs`;
  if (a < 1e9) return `${s}${a / 1e6} ms`;
  return `${s}${a / 1e9} s`;
}

export function drawHistogram(
  canvas: HTMLCanvasElement,
  width: number,
  height: number,
  total: Bin[],
  interval: Bin[] | null,
  marks: Mark[],
  perDecade: number,
): void {
  const dpr = window.devicePixelRatio || 1;
  if (canvas.width !== Math.round(width * dpr) || canvas.height !== Math.round(height * dpr)) {
    canvas.width = Math.round(width * dpr);
    canvas.height = Math.round(height * dpr);
    canvas.style.height = `${height}px`;
  }
  const g = canvas.getContext("2d");
  if (!g) return;
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, width, height);
  g.font = "10px system-ui, sans-serif";
  g.fillStyle = "#5f6b76";
  if (total.length === 0) {
    g.fillText("no samples yet", PAD.left, height / 2);
    return;
  }
  // x: whole bins on the symlog axis, zero and ±1 µs always in view for signed data
  let k0 = total[0].k;
  let k1 = total[total.length - 1].k + 1;
  for (const m of marks)
    if (m.ns !== null) {
      const k = Math.floor(symlog(m.ns) * perDecade);
      k0 = Math.min(k0, k);
      k1 = Math.max(k1, k + 1);
    }
  if (k0 < 0) k1 = Math.max(k1, perDecade);
  k0 = Math.min(k0, 0);
  const x0 = k0 / perDecade;
  const x1 = k1 / perDecade;
  const pw = width - PAD.left - PAD.right;
  const ph = height - PAD.top - PAD.bottom;
  const px = (y: number) => PAD.left + ((y - x0) / (x1 - x0)) * pw;
  // y: log10(count), from 0.5 so that a single count still shows
  let cmax = 1;
  for (const b of total) cmax = Math.max(cmax, b.count);
  const top = Math.ceil(Math.log10(cmax) + 0.01);
  const base = Math.log10(0.5);
  const py = (c: number) => PAD.top + ph - ((Math.log10(c) - base) / (top - base)) * ph;
  // grid: decades of count, decades of time
  g.strokeStyle = "#eef1f4";
  g.lineWidth = 1;
  g.beginPath();
  for (let d = 0; d <= top; d++) {
    const y = Math.round(py(10 ** d)) + 0.5;
    g.moveTo(PAD.left, y);
    g.lineTo(PAD.left + pw, y);
    g.fillText(d < 4 ? String(10 ** d) : `1e${d}`, 2, y + 3);
  }
  // 0, ±1 µs, ±10 µs, ... as far as the axis goes; every other decade when they crowd
  const ticks = [0];
  for (let ns = 1e3; ns < 1e11; ns *= 10)
    for (const v of [ns, -ns]) if (symlog(v) >= x0 && symlog(v) <= x1) ticks.push(v);
  ticks.sort((a, b) => a - b);
  const crowded = ticks.length > 9;
  for (const ns of ticks) {
    const x = Math.round(px(symlog(ns))) + 0.5;
    g.moveTo(x, PAD.top);
    g.lineTo(x, PAD.top + ph);
    const decade = ns === 0 ? 0 : Math.round(Math.log10(Math.abs(ns)));
    if (!crowded || decade % 2 === 1 || ns === 0) {
      const label = decadeLabel(ns);
      const w = g.measureText(label).width;
      g.fillText(label, Math.min(width - PAD.right - w, Math.max(0, x - w / 2)), height - 8);
    }
  }
  g.stroke();
  const bars = (bins: Bin[], color: string, inset: number) => {
    g.fillStyle = color;
    for (const b of bins) {
      const a = px(b.k / perDecade) + inset;
      const w = Math.max(1, px((b.k + 1) / perDecade) - inset - a);
      const y = py(b.count);
      g.fillRect(a, y, w, PAD.top + ph - y);
    }
  };
  bars(total, "#9ec5ee", 0.5);
  if (interval) bars(interval, "#0b63c5", 2);
  g.strokeStyle = "#9aa5b1";
  g.strokeRect(PAD.left + 0.5, PAD.top + 0.5, pw, ph);
  let lx = -Infinity;
  for (const m of marks) {
    if (m.ns === null) continue;
    const x = Math.round(px(symlog(m.ns))) + 0.5;
    g.strokeStyle = m.color;
    g.beginPath();
    g.moveTo(x, PAD.top);
    g.lineTo(x, PAD.top + ph);
    g.stroke();
    g.fillStyle = m.color;
    const w = g.measureText(m.label).width;
    const tx = Math.min(x + 2, width - PAD.right - w);
    // a label that would run into the previous one goes inside the plot, below the top
    const y = tx < lx ? PAD.top + 10 : PAD.top - 3;
    g.fillText(m.label, tx, y);
    if (tx >= lx) lx = tx + w + 4;
  }
}
