// hist.test.ts -- quantiles from buckets, the difference of two polls, log re-binning.
import { describe, expect, it } from "vitest";
import { diffHist, figures, type Hist, logBins, quantile, symexp, symlog } from "../../src/plot/hist";

/** irpd's log-linear bucket of a non-negative value: exact below 32, then 32 per power of two. */
function bucketOf(v: number): { low: number; width: number } {
  if (v < 32) return { low: v, width: 1 };
  const e = Math.floor(Math.log2(v));
  const width = 2 ** (e - 5);
  return { low: Math.floor(v / width) * width, width };
}

/** A histogram as GET /jitter/histograms gives it; negative values use their magnitude's bucket. */
function hist(values: number[]): Hist {
  const m = new Map<number, { low_ns: number; width_ns: number; count: number }>();
  for (const v of values) {
    const b = bucketOf(Math.abs(v));
    const low = v < 0 ? -(b.low + b.width - 1) : b.low;
    const e = m.get(low) ?? { low_ns: low, width_ns: b.width, count: 0 };
    e.count++;
    m.set(low, e);
  }
  return {
    count: values.length,
    min: values.length ? Math.min(...values) : 0,
    max: values.length ? Math.max(...values) : 0,
    buckets: [...m.values()].sort((a, b) => a.low_ns - b.low_ns),
  };
}

describe("quantile", () => {
  it("is the middle of the bucket holding rank ⌈q·n⌉, as irpd gives it", () => {
    const h = hist([10, 1000, 1000, 1000, 5000, 20000]);
    expect(quantile(h, 0.5)).toBe(999.5); // rank 3: bucket [992, 1008)
    expect(quantile(h, 0.8)).toBe(5055.5); // rank 5: bucket [4992, 5120)
    expect(quantile(h, 0.01)).toBe(10); // rank 1: an exact bucket
  });

  it("does not depend on the order the buckets come in", () => {
    const h = hist([-3000, -10, 5, 7000, 7000]);
    const shuffled = { ...h, buckets: [...h.buckets].reverse() };
    for (const q of [0.1, 0.5, 0.9]) expect(quantile(shuffled, q)).toBe(quantile(h, q));
  });

  it("stays within min and max, and is null when empty", () => {
    const h = hist([40000]);
    expect(quantile(h, 0.99)).toBe(40000);
    expect(quantile(hist([]), 0.5)).toBeNull();
  });

  it("walks signed buckets from the most negative", () => {
    const h = hist([-3000, -3000, -10, 5, 7000]);
    const q = quantile(h, 0.2)!;
    expect(q).toBeLessThan(-2900);
    expect(q).toBeGreaterThanOrEqual(-3000 - 64);
    expect(quantile(h, 0.6)).toBe(-10);
    expect(quantile(h, 1)).toBe(6975.5); // the middle of [6912, 7040), not the max
  });

  it("gives p50, p99 and max together", () => {
    const vals = Array.from({ length: 1000 }, (_, i) => i * 10);
    const f = figures(hist(vals));
    expect(f.count).toBe(1000);
    expect(f.max).toBe(9990);
    expect(Math.abs(f.p50! - 4990) / 4990).toBeLessThan(0.032);
    expect(Math.abs(f.p99! - 9890) / 9890).toBeLessThan(0.032);
  });
});

describe("diffHist", () => {
  const a = [1000, 2000, -500];
  const b = [3000, 3000, 40, -800];

  it("is the histogram of the samples between two polls", () => {
    const d = diffHist(hist([...a, ...b]), hist(a))!;
    expect(d).not.toBeNull();
    const want = hist(b);
    expect(d.count).toBe(4);
    expect(d.buckets).toEqual(want.buckets);
    expect(quantile(d, 0.5)).toBe(quantile(want, 0.5));
  });

  it("has the exact max and min when they moved in the interval, else the extreme bucket's edge", () => {
    const moved = diffHist(hist([...a, ...b]), hist(a))!;
    expect(moved.max).toBe(3000); // above the earlier max 2000: exact
    expect(moved.min).toBe(-800); // below the earlier min −500: exact
    const inside = diffHist(hist([...a, 1500]), hist(a))!;
    const b15 = hist([1500]).buckets[0];
    expect(inside.max).toBe(b15.low_ns + b15.width_ns - 1); // the max of the whole stays 2000
    expect(inside.min).toBe(b15.low_ns);
  });

  it("is empty when nothing happened", () => {
    const d = diffHist(hist(a), hist(a))!;
    expect(d.count).toBe(0);
    expect(d.buckets).toEqual([]);
    expect(quantile(d, 0.5)).toBeNull();
  });

  it("is null when a count went down (irpd restarted)", () => {
    expect(diffHist(hist([1000]), hist([1000, 2000]))).toBeNull();
    expect(diffHist(hist([5000, 5000]), hist([1000]))).toBeNull(); // the 1000 bucket vanished
  });
});

describe("log bins", () => {
  it("maps the symmetric log axis both ways", () => {
    for (const v of [-1e6, -1000, -1, 0, 1, 999, 1e5, 3e7]) expect(symexp(symlog(v))).toBeCloseTo(v, 6);
    expect(symlog(9000)).toBeCloseTo(1, 10); // one decade beyond 1 µs
    expect(symlog(-9000)).toBeCloseTo(-1, 10);
  });

  it("counts each bucket in the bin of its middle, ascending, covering the values", () => {
    const h = hist([-20000, -20000, -50, 10, 1000, 1000, 1000, 100000]);
    const bins = logBins(h.buckets, 8);
    expect(bins.reduce((s, b) => s + b.count, 0)).toBe(8);
    for (let i = 1; i < bins.length; i++) expect(bins[i].k).toBeGreaterThan(bins[i - 1].k);
    for (const b of bins) expect(b.hi).toBeGreaterThan(b.lo);
    const at = (v: number) => bins.find((b) => b.lo <= v && v < b.hi)!;
    expect(at(1000).count).toBe(3);
    expect(at(-20000).count).toBe(2);
    expect(at(100000).count).toBe(1);
  });
});
