// hist.ts -- the arithmetic of irpd's timing histograms as GET /jitter/histograms gives them
// (non-empty buckets [low_ns, low_ns + width_ns), cumulative since irpd started): quantiles as irpd
// computes them, the histogram of one poll interval (the difference of two polls), and re-binning
// on a symmetric log scale for drawing.

export interface Bucket {
  low_ns: number;
  width_ns: number;
  count: number;
}

export interface Hist {
  count: number;
  min: number;
  max: number;
  buckets: Bucket[];
}

function total(h: Hist): number {
  let n = 0;
  for (const b of h.buckets) n += b.count;
  return n;
}

/** The buckets in ascending order (as the agent sends them; sorted here if they are not). */
function ascending(buckets: Bucket[]): Bucket[] {
  for (let i = 1; i < buckets.length; i++)
    if (buckets[i].low_ns < buckets[i - 1].low_ns) return [...buckets].sort((a, b) => a.low_ns - b.low_ns);
  return buckets;
}

/** The q-quantile as irpd gives it: the middle of the bucket holding rank ⌈q·n⌉, within [min, max];
 * null when the histogram is empty. */
export function quantile(h: Hist, q: number): number | null {
  const n = total(h);
  if (n === 0) return null;
  const rank = Math.min(n, Math.max(1, Math.ceil(q * n)));
  const lo = Math.min(h.min, h.max);
  let seen = 0;
  for (const b of ascending(h.buckets)) {
    seen += b.count;
    if (seen >= rank) return Math.min(h.max, Math.max(lo, b.low_ns + (b.width_ns - 1) / 2));
  }
  return h.max;
}

export interface Figures {
  count: number;
  min: number | null;
  p50: number | null;
  p99: number | null;
  max: number | null;
}

export function figures(h: Hist): Figures {
  const n = total(h);
  return {
    count: n,
    min: n ? h.min : null,
    p50: quantile(h, 0.5),
    p99: quantile(h, 0.99),
    max: n ? h.max : null,
  };
}

const key = (b: Bucket) => `${b.low_ns}/${b.width_ns}`;

/** The histogram of what happened between two polls of the same record (cur − prev), or null when
 * some count went down (irpd restarted in between: cur alone is the interval's best guess).
 * min and max are exact when they moved in the interval, else the edge of the extreme bucket. */
export function diffHist(cur: Hist, prev: Hist): Hist | null {
  const before = new Map<string, number>();
  for (const b of prev.buckets) before.set(key(b), b.count);
  const buckets: Bucket[] = [];
  for (const b of ascending(cur.buckets)) {
    const p = before.get(key(b)) ?? 0;
    before.delete(key(b));
    if (b.count < p) return null;
    if (b.count > p) buckets.push({ low_ns: b.low_ns, width_ns: b.width_ns, count: b.count - p });
  }
  for (const c of before.values()) if (c > 0) return null;
  if (cur.count < prev.count) return null;
  const n = buckets.reduce((s, b) => s + b.count, 0);
  if (n === 0) return { count: 0, min: 0, max: 0, buckets };
  const first = buckets[0];
  const last = buckets[buckets.length - 1];
  const hadAny = prev.count > 0;
  const max = !hadAny || cur.max > prev.max ? cur.max : Math.min(cur.max, last.low_ns + last.width_ns - 1);
  const min = !hadAny || cur.min < prev.min ? cur.min : Math.max(cur.min, first.low_ns);
  return { count: cur.count - prev.count, min, max, buckets };
}

// ---- the symmetric log scale: linear within ±LIN, logarithmic beyond --------------------------

export const LIN_NS = 1000; // 1 µs

/** ns → position on the symmetric log axis (1 per decade beyond LIN). */
export function symlog(v: number, lin = LIN_NS): number {
  return Math.sign(v) * Math.log10(1 + Math.abs(v) / lin);
}

export function symexp(y: number, lin = LIN_NS): number {
  return Math.sign(y) * lin * (10 ** Math.abs(y) - 1);
}

export interface Bin {
  /** bin index on the symlog axis: covers [k, k+1) / perDecade */
  k: number;
  lo: number;
  hi: number;
  count: number;
}

/** The buckets re-binned into `perDecade` bins per decade of the symmetric log axis (each bucket
 * counted in the bin of its middle), ascending. */
export function logBins(buckets: readonly Bucket[], perDecade = 8, lin = LIN_NS): Bin[] {
  const bins = new Map<number, number>();
  for (const b of buckets) {
    if (b.count <= 0) continue;
    const mid = b.low_ns + (b.width_ns - 1) / 2;
    const k = Math.floor(symlog(mid, lin) * perDecade);
    bins.set(k, (bins.get(k) ?? 0) + b.count);
  }
  return [...bins.entries()]
    .sort((a, b) => a[0] - b[0])
    .map(([k, count]) => ({ k, lo: symexp(k / perDecade, lin), hi: symexp((k + 1) / perDecade, lin), count }));
}
