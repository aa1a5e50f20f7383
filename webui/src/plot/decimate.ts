// decimate.ts -- what a time plot draws: at most two points (the min and the max, in the order
// they came) per bucket of samples, a bucket being about one pixel wide, and a gap (null) where
// samples are missing (in a sparse ring, where a series has no sample the line goes on to its
// next one: undefined, not null).  The live view keeps finished buckets and computes only the new samples
// of each frame, so a frame's work does not grow with the window.
import type { SampleRing } from "./ring";

export interface DrawData {
  x: number[];
  /** null: a gap (the pen lifts); undefined: no sample of this series here (drawn across) */
  ys: (number | null | undefined)[][];
}

export function emptyDraw(channels: number): DrawData {
  return { x: [], ys: Array.from({ length: channels }, () => []) };
}

export function clearDraw(d: DrawData, channels: number): void {
  d.x.length = 0;
  if (d.ys.length !== channels) d.ys = Array.from({ length: channels }, () => []);
  for (const y of d.ys) y.length = 0;
}

/** One bucket: its points' times, its channels' first and second values (NaN: none). */
class Buckets {
  x1: Float64Array;
  x2: Float64Array;
  /** NaN is emitted as undefined (a sparse ring's "no sample here"), else as null (a gap) */
  missing: null | undefined = null;
  np: Uint8Array;
  gap: Uint8Array;
  ya: Float64Array[];
  yb: Float64Array[];
  constructor(
    readonly size: number,
    readonly channels: number,
  ) {
    this.x1 = new Float64Array(size);
    this.x2 = new Float64Array(size);
    this.np = new Uint8Array(size);
    this.gap = new Uint8Array(size);
    this.ya = Array.from({ length: channels }, () => new Float64Array(size));
    this.yb = Array.from({ length: channels }, () => new Float64Array(size));
  }

  /** Fills slot s from the ring's logical samples [a, b). */
  compute(s: number, ring: SampleRing, a: number, b: number): void {
    const dec = ring.decimation;
    this.missing = ring.sparse ? undefined : null;
    let gap = !ring.sparse && a > 0 && ring.seqAt(a) - ring.seqAt(a - 1) !== dec;
    for (let i = a + 1; i < b && !gap && !ring.sparse; i++) if (ring.seqAt(i) - ring.seqAt(i - 1) !== dec) gap = true;
    this.gap[s] = gap ? 1 : 0;
    this.x1[s] = ring.tAt(a);
    this.x2[s] = ring.tAt(b - 1);
    const single = b - a === 1;
    this.np[s] = single ? 1 : 2;
    const cap = ring.capacity;
    const p0 = ring.slot(a);
    for (let c = 0; c < this.channels; c++) {
      const col = ring.cols[c];
      if (single) {
        this.ya[c][s] = col[p0];
        this.yb[c][s] = NaN;
        continue;
      }
      let min = Infinity;
      let max = -Infinity;
      let iMin = -1;
      let iMax = -1;
      let p = p0;
      for (let i = a; i < b; i++) {
        const v = col[p];
        if (v < min) {
          min = v;
          iMin = i;
        }
        if (v > max) {
          max = v;
          iMax = i;
        }
        if (++p === cap) p = 0;
      }
      if (iMin < 0) {
        this.ya[c][s] = NaN;
        this.yb[c][s] = NaN;
      } else if (iMin <= iMax) {
        this.ya[c][s] = min;
        this.yb[c][s] = max;
      } else {
        this.ya[c][s] = max;
        this.yb[c][s] = min;
      }
    }
  }

  /** Appends slot s to `out` (x shifted by xOff). */
  emit(s: number, xOff: number, out: DrawData): number {
    let n = 0;
    if (this.gap[s] && out.x.length) {
      out.x.push((out.x[out.x.length - 1] + this.x1[s] + xOff) / 2);
      for (const y of out.ys) y.push(null);
      n++;
    }
    out.x.push(this.x1[s] + xOff);
    for (let c = 0; c < this.channels; c++) {
      const v = this.ya[c][s];
      out.ys[c].push(Number.isNaN(v) ? this.missing : v);
    }
    n++;
    if (this.np[s] === 2) {
      out.x.push(this.x2[s] + xOff);
      for (let c = 0; c < this.channels; c++) {
        const v = this.yb[c][s];
        out.ys[c].push(Number.isNaN(v) ? this.missing : v);
      }
      n++;
    }
    return n;
  }
}

/** Samples per bucket for `samples` samples drawn across `pixels` pixels: every sample while
 * there are no more than pixels, else buckets two pixels wide (two points each: at most one point
 * per pixel per series, which bounds a frame's drawing whatever the rate and the window). */
export function bucketSize(samples: number, pixels: number): number {
  const px = Math.max(2, Math.floor(pixels));
  return samples <= px ? 1 : Math.ceil(samples / Math.floor(px / 2));
}

/** The points of the ring's logical samples [i0, i1) in buckets of `size`, appended to `out`. */
export function decimateRange(
  ring: SampleRing,
  i0: number,
  i1: number,
  size: number,
  xOff: number,
  out: DrawData,
): void {
  const b = new Buckets(1, ring.channels);
  for (let a = i0; a < i1; a += size) {
    b.compute(0, ring, a, Math.min(i1, a + size));
    b.emit(0, xOff, out);
  }
}

/** The buckets of a live ring, kept between frames: bucket k holds the samples whose absolute
 * index (SampleRing.total) is in [k × size, (k + 1) × size). */
export class LiveDecimator {
  private b: Buckets;
  private kLo = 0;
  private kHi = 0;
  private lastPartial = false;
  private ring: SampleRing | null = null;
  private resets = -1;
  private total = 0;

  constructor(
    readonly size: number,
    ringCapacity: number,
    readonly channels: number,
  ) {
    this.b = new Buckets(Math.ceil(ringCapacity / size) + 2, channels);
  }

  /** Brings the buckets up to the ring's newest sample; the cost is that of the new samples. */
  update(ring: SampleRing): void {
    if (ring !== this.ring || ring.resets !== this.resets || ring.total < this.total) {
      this.ring = ring;
      this.resets = ring.resets;
      this.kLo = this.kHi = 0;
      this.lastPartial = false;
    }
    this.total = ring.total;
    const size = this.size;
    const first = ring.firstAbs;
    const total = ring.total;
    if (ring.length === 0) {
      this.kLo = this.kHi = 0;
      this.lastPartial = false;
      return;
    }
    const kFirst = Math.ceil(first / size);
    if (this.kLo < kFirst) this.kLo = kFirst;
    if (this.kHi < this.kLo) {
      this.kHi = this.kLo;
      this.lastPartial = false;
    }
    let k = this.lastPartial ? this.kHi - 1 : this.kHi;
    if (k < this.kLo) k = this.kLo;
    const kEnd = Math.ceil(total / size);
    const slots = this.b.size;
    for (; k < kEnd; k++) {
      const a = k * size - first;
      const e = Math.min((k + 1) * size, total) - first;
      this.b.compute(k % slots, ring, a, e);
    }
    this.kHi = kEnd;
    this.lastPartial = total % size !== 0;
  }

  /** Appends the points of the buckets that overlap [tMin, tMax]; returns how many. */
  output(tMin: number, tMax: number, xOff: number, out: DrawData): number {
    const slots = this.b.size;
    let n = 0;
    for (let k = this.kLo; k < this.kHi; k++) {
      const s = k % slots;
      if (this.b.x2[s] < tMin) continue;
      if (this.b.x1[s] > tMax) break;
      n += this.b.emit(s, xOff, out);
    }
    return n;
  }
}
