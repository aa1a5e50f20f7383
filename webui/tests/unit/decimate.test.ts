// decimate.test.ts -- min/max buckets for drawing, live (incremental) and frozen (on demand).
import { describe, expect, it } from "vitest";
import { bucketSize, decimateRange, emptyDraw, LiveDecimator } from "../../src/plot/decimate";
import { SampleRing } from "../../src/plot/ring";

function ringOf(values: number[], first = 1, capacity = 1000): SampleRing {
  const r = new SampleRing(capacity, 1);
  r.push(
    first,
    1,
    Float64Array.from(values, (_, k) => first + k),
    [Float64Array.from(values)],
  );
  return r;
}

describe("bucketSize", () => {
  it("draws every sample while there are no more than pixels, else two pixels a bucket", () => {
    expect(bucketSize(500, 1000)).toBe(1);
    expect(bucketSize(1000, 1000)).toBe(1);
    expect(bucketSize(1001, 1000)).toBe(3);
    expect(bucketSize(10000, 1000)).toBe(20);
    expect(bucketSize(600000, 1000)).toBe(1200);
  });
});

describe("decimateRange", () => {
  it("gives each bucket's min and max in the order they came", () => {
    const r = ringOf([0, 5, -3, 1, /**/ 2, -7, 9, 0, /**/ 4]);
    const d = emptyDraw(1);
    decimateRange(r, 0, r.length, 4, 100, d);
    // bucket 1: max 5 (k=1) before min −3 (k=2); bucket 2: min −7 before max 9; bucket 3: one sample
    expect(d.ys[0]).toEqual([5, -3, -7, 9, 4]);
    expect(d.x).toEqual([101, 104, 105, 108, 109]); // first and last time of each bucket, shifted by 100
  });

  it("draws every sample with buckets of one", () => {
    const r = ringOf([3, 1, 2]);
    const d = emptyDraw(1);
    decimateRange(r, 0, 3, 1, 0, d);
    expect(d.x).toEqual([1, 2, 3]);
    expect(d.ys[0]).toEqual([3, 1, 2]);
  });

  it("breaks the line where seq jumps, and leaves NaN out", () => {
    const r = new SampleRing(100, 1);
    r.push(1, 1, Float64Array.of(1, 2), [Float64Array.of(1, NaN)]);
    r.push(10, 1, Float64Array.of(10, 11), [Float64Array.of(4, 5)]);
    const d = emptyDraw(1);
    decimateRange(r, 0, r.length, 1, 0, d);
    expect(d.x).toEqual([1, 2, 6, 10, 11]);
    expect(d.ys[0]).toEqual([1, null, null, 4, 5]);
  });
});

describe("LiveDecimator", () => {
  it("gives what decimateRange gives, frame by frame, while the ring wraps", () => {
    const r = new SampleRing(200, 2);
    const live = new LiveDecimator(7, r.capacity, 2);
    let seq = 1;
    for (let f = 0; f < 40; f++) {
      const n = 1 + ((f * 13) % 17);
      const t = Float64Array.from({ length: n }, (_, k) => seq + k);
      const a = Float64Array.from(t, (v) => Math.sin(v * 0.7) * 10);
      const b = Float64Array.from(t, (v) => (v * 37) % 11);
      r.push(seq, 1, t, [a, b]);
      seq += n;
      live.update(r);
      const tMax = r.tAt(r.length - 1);
      const got = emptyDraw(2);
      live.output(tMax - 150, tMax, 0, got);
      // the same buckets (aligned on the absolute index) computed from scratch
      const want = emptyDraw(2);
      const first = r.firstAbs;
      let a0 = Math.ceil(first / 7) * 7 - first;
      while (a0 < r.length && r.tAt(Math.min(r.length, a0 + 7) - 1) < tMax - 150) a0 += 7;
      decimateRange(r, a0, r.length, 7, 0, want);
      expect(got).toEqual(want);
    }
  });

  it("starts again after a reset of the ring", () => {
    const r = ringOf([1, 2, 3, 4, 5, 6], 100);
    const live = new LiveDecimator(2, r.capacity, 1);
    live.update(r);
    r.push(1, 1, Float64Array.of(1, 2, 3), [Float64Array.of(7, 8, 9)]); // seq back: reset
    live.update(r);
    const d = emptyDraw(1);
    live.output(-Infinity, Infinity, 0, d);
    expect(d.ys[0]).toEqual([7, 8, 9]);
  });
});
