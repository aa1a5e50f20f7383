// counters.ts -- how much a cumulative counter (overruns, misses) grew lately: samples kept for a
// window, started again when irpd restarts (its counters begin at zero).
export interface CounterSample {
  t: number;
  value: number;
}

export class CounterWindow {
  private samples: CounterSample[] = [];
  private owner: unknown = undefined;

  constructor(private readonly windowMs = 60_000) {}

  /** Adds a sample of the counter as read from `owner` (irpd's pid); returns the growth within the window. */
  add(t: number, value: number, owner: unknown): number {
    if (owner !== this.owner || (this.samples.length && value < this.samples[this.samples.length - 1].value)) {
      this.samples = [];
      this.owner = owner;
    }
    this.samples.push({ t, value });
    while (this.samples.length > 1 && this.samples[0].t < t - this.windowMs) this.samples.shift();
    return value - this.samples[0].value;
  }
}
