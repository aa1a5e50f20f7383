// ring.test.ts -- the plot panels' sample ring: wraparound, window extraction, seq continuity.
import { describe, expect, it } from "vitest";
import { SampleRing } from "../../src/plot/ring";

/** n samples from seq `first`, t = seq / 1000 s, channel c = seq * 10 + c. */
function frame(first: number, n: number, channels = 2, dec = 1) {
  const t = Float64Array.from({ length: n }, (_, k) => (first + k * dec) / 1000);
  const cols = Array.from({ length: channels }, (_, c) =>
    Float64Array.from({ length: n }, (_, k) => (first + k * dec) * 10 + c),
  );
  return { t, cols };
}

function push(r: SampleRing, first: number, n: number, dec = 1) {
  const f = frame(first, n, r.channels, dec);
  return r.push(first, dec, f.t, f.cols);
}

const seqs = (r: SampleRing) => Array.from({ length: r.length }, (_, i) => r.seqAt(i));

describe("SampleRing", () => {
  it("keeps the newest samples in order across the wrap", () => {
    const r = new SampleRing(5, 2);
    push(r, 1, 3);
    expect(seqs(r)).toEqual([1, 2, 3]);
    push(r, 4, 4);
    expect(r.length).toBe(5);
    expect(r.total).toBe(7);
    expect(r.firstAbs).toBe(2);
    expect(seqs(r)).toEqual([3, 4, 5, 6, 7]);
    for (let i = 0; i < r.length; i++) {
      expect(r.tAt(i)).toBe(r.seqAt(i) / 1000);
      expect(r.valueAt(0, i)).toBe(r.seqAt(i) * 10);
      expect(r.valueAt(1, i)).toBe(r.seqAt(i) * 10 + 1);
    }
  });

  it("keeps only the end of a frame longer than itself", () => {
    const r = new SampleRing(4, 1);
    push(r, 10, 2);
    push(r, 12, 9);
    expect(seqs(r)).toEqual([17, 18, 19, 20]);
    expect(r.total).toBe(11);
    expect(r.nextSeq).toBe(21);
  });

  it("finds the samples of a time window, bounds included", () => {
    const r = new SampleRing(8, 1);
    push(r, 1, 12); // keeps 5..12
    expect(r.range(0.006, 0.009)).toEqual([1, 5]); // seq 6..9
    expect(r.range(0.0065, 0.0085)).toEqual([2, 4]); // seq 7, 8
    expect(r.range(0, 1)).toEqual([0, 8]);
    expect(r.range(0.5, 1)).toEqual([8, 8]);
    expect(r.range(0, 0.001)).toEqual([0, 0]);
  });

  it("counts samples missing between frames and resets when seq goes back", () => {
    const r = new SampleRing(100, 1);
    expect(push(r, 1, 10)).toEqual({ gap: 0, reset: false });
    expect(push(r, 11, 5)).toEqual({ gap: 0, reset: false });
    expect(push(r, 20, 5)).toEqual({ gap: 4, reset: false }); // 16..19 missing
    expect(r.gapSamples).toBe(4);
    expect(push(r, 1, 3)).toEqual({ gap: 0, reset: true }); // irpd restarted: seq from 1 again
    expect(seqs(r)).toEqual([1, 2, 3]);
    expect(r.resets).toBe(1);
  });

  it("measures gaps in samples of a decimated stream", () => {
    const r = new SampleRing(100, 1);
    push(r, 10, 3, 10); // 10, 20, 30
    expect(push(r, 60, 1, 10).gap).toBe(2); // 40 and 50 missing
  });

  it("stores NaN for a channel a frame does not carry", () => {
    const r = new SampleRing(4, 2);
    const f = frame(1, 2, 2);
    r.push(1, 1, f.t, [f.cols[0], undefined]);
    expect(r.valueAt(0, 1)).toBe(20);
    expect(r.valueAt(1, 1)).toBeNaN();
  });

  it("copies into another capacity and another set of channels", () => {
    const r = new SampleRing(6, 2);
    push(r, 1, 9); // keeps 4..9
    const small = r.copy(3);
    expect(seqs(small)).toEqual([7, 8, 9]);
    expect(small.nextSeq).toBe(10);
    const remapped = r.copy(6, [1, -1]);
    expect(remapped.channels).toBe(2);
    expect(remapped.valueAt(0, 0)).toBe(41);
    expect(remapped.valueAt(1, 0)).toBeNaN();
    // and it goes on from there
    push(remapped, 10, 2);
    expect(seqs(remapped)).toEqual([5, 6, 7, 8, 9, 10, 11].slice(-6));
    expect(remapped.valueAt(1, 5)).toBe(111);
  });
});
