// ring.ts -- the samples of one plot panel: a ring of rows (seq, due time, one value per channel)
// holding the last `capacity` samples, checked for seq continuity as frames arrive; or a fixed
// table of rows (a capture's shot, SampleRing.of) that nothing is added to.

export interface PushResult {
  /** samples missing between the previous frame and this one (by seq) */
  gap: number;
  /** seq went backwards (irpd restarted): the ring was emptied first */
  reset: boolean;
}

/** A fixed table of rows for a panel to show instead of the stream (the Scope page's shots). */
export interface FixedRows {
  /** one per column: the series' names */
  names: string[];
  /** row k's seq (for a single shot, the trace row's) and its x value (seconds) */
  seq: ArrayLike<number>;
  t: ArrayLike<number>;
  /** one per name; NaN: no value */
  cols: ArrayLike<number>[];
  /** seq step between rows that follow each other (a bigger step is drawn as a gap) */
  decimation: number;
  /** rows of several tables merged on one x axis: NaN is "no sample of this series here" (the
   * line goes on to its next sample) and seq steps are not checked */
  sparse: boolean;
  /** vertical lines drawn at these x values (a trigger) */
  marks: { x: number; label: string }[];
}

export class SampleRing {
  readonly seq: Float64Array;
  readonly t: Float64Array;
  readonly cols: Float64Array[];
  /** next physical slot to write */
  private head = 0;
  length = 0;
  /** samples pushed since the last reset: the absolute index of the next sample */
  total = 0;
  /** the seq the next sample should have, null before the first */
  nextSeq: number | null = null;
  decimation = 1;
  /** samples missing between frames since the ring was made (not counting resets) */
  gapSamples = 0;
  resets = 0;
  /** NaN means "no sample of this channel at this row" (FixedRows.sparse) */
  sparse = false;

  /** A full ring holding exactly the given rows (nothing is pushed to it afterwards). */
  static of(rows: FixedRows): SampleRing {
    const n = rows.t.length;
    const r = new SampleRing(Math.max(1, n), rows.cols.length);
    r.seq.set(rows.seq);
    r.t.set(rows.t);
    for (let c = 0; c < rows.cols.length; c++) r.cols[c].set(rows.cols[c]);
    r.head = n % r.capacity;
    r.length = r.total = n;
    r.decimation = rows.decimation;
    r.nextSeq = n ? rows.seq[n - 1] + rows.decimation : null;
    r.sparse = rows.sparse;
    return r;
  }

  constructor(
    readonly capacity: number,
    readonly channels: number,
  ) {
    if (!(capacity >= 1)) throw new RangeError(`ring capacity ${capacity}`);
    this.seq = new Float64Array(capacity);
    this.t = new Float64Array(capacity);
    this.cols = Array.from({ length: channels }, () => new Float64Array(capacity));
  }

  clear(): void {
    this.head = 0;
    this.length = 0;
    this.total = 0;
    this.nextSeq = null;
  }

  /** Appends a frame: sample k has seq firstSeq + k × decimation; a missing column is NaN. */
  push(
    firstSeq: number,
    decimation: number,
    t: ArrayLike<number>,
    cols: readonly (ArrayLike<number> | undefined)[],
  ): PushResult {
    const n = t.length;
    let gap = 0;
    let reset = false;
    if (this.nextSeq !== null && (firstSeq < this.nextSeq || decimation !== this.decimation)) {
      this.clear();
      this.resets++;
      reset = true;
    } else if (this.nextSeq !== null && firstSeq > this.nextSeq) {
      gap = Math.round((firstSeq - this.nextSeq) / decimation);
      this.gapSamples += gap;
    }
    this.decimation = decimation;
    if (n === 0) return { gap, reset };
    this.nextSeq = firstSeq + n * decimation;
    const cap = this.capacity;
    const skip = Math.max(0, n - cap); // a frame longer than the ring: only its end is kept
    let p = (this.head + skip) % cap;
    for (let k = skip; k < n; k++) {
      this.seq[p] = firstSeq + k * decimation;
      this.t[p] = t[k];
      p++;
      if (p === cap) p = 0;
    }
    for (let c = 0; c < this.channels; c++) {
      const src = cols[c];
      const dst = this.cols[c];
      p = (this.head + skip) % cap;
      for (let k = skip; k < n; k++) {
        dst[p] = src ? src[k] : NaN;
        p++;
        if (p === cap) p = 0;
      }
    }
    this.head = (this.head + n) % cap;
    this.total += n;
    this.length = Math.min(cap, this.length + n);
    return { gap, reset };
  }

  /** The physical slot of logical index i (0 = oldest kept sample). */
  slot(i: number): number {
    let p = this.head - this.length + i;
    if (p < 0) p += this.capacity;
    else if (p >= this.capacity) p -= this.capacity;
    return p;
  }

  seqAt(i: number): number {
    return this.seq[this.slot(i)];
  }
  tAt(i: number): number {
    return this.t[this.slot(i)];
  }
  valueAt(c: number, i: number): number {
    return this.cols[c][this.slot(i)];
  }
  /** the absolute index (see `total`) of logical index 0 */
  get firstAbs(): number {
    return this.total - this.length;
  }

  /** The first logical index whose time is ≥ time (length when none). */
  lowerBound(time: number): number {
    let lo = 0;
    let hi = this.length;
    while (lo < hi) {
      const mid = (lo + hi) >>> 1;
      if (this.t[this.slot(mid)] < time) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }

  /** The first logical index whose time is > time (length when none). */
  upperBound(time: number): number {
    let lo = 0;
    let hi = this.length;
    while (lo < hi) {
      const mid = (lo + hi) >>> 1;
      if (this.t[this.slot(mid)] <= time) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }

  /** Logical indices [i0, i1) of the samples with t0 ≤ t ≤ t1. */
  range(t0: number, t1: number): [number, number] {
    const i0 = this.lowerBound(t0);
    return [i0, Math.max(i0, this.upperBound(t1))];
  }

  /** A new ring of `capacity` holding the newest samples of this one, with channel c taken from
   * this ring's channel map[c] (-1: a new channel, NaN so far). */
  copy(capacity = this.capacity, map: readonly number[] = this.cols.map((_, c) => c)): SampleRing {
    const r = new SampleRing(capacity, map.length);
    const n = Math.min(this.length, capacity);
    const from = this.length - n;
    for (let k = 0; k < n; k++) {
      const p = this.slot(from + k);
      r.seq[k] = this.seq[p];
      r.t[k] = this.t[p];
      for (let c = 0; c < map.length; c++) r.cols[c][k] = map[c] >= 0 ? this.cols[map[c]][p] : NaN;
    }
    r.head = n % capacity;
    r.length = n;
    r.total = n;
    r.nextSeq = this.nextSeq;
    r.decimation = this.decimation;
    r.gapSamples = this.gapSamples;
    r.resets = this.resets;
    r.sparse = this.sparse;
    return r;
  }
}
