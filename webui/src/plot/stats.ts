// stats.ts -- the plot page's own measurements, readable by a benchmark as
// window.__induropPlotStats: frames (animation frames seen), draws (frames that redrew),
// frameTimes (ms of work in each recent frame, drawing included), frameIntervals (ms between
// recent frames), fps (over the last second), samples (rows received by the panels),
// uiDropped (samples that reached the UI but were not kept), points (drawn in the last frame),
// drawEvery (1, or 2–3 while frames come late and the plots draw only every n-th frame).
export interface PlotStats {
  frames: number;
  draws: number;
  frameTimes: number[];
  frameIntervals: number[];
  fps: number;
  samples: number;
  uiDropped: number;
  points: number;
  panels: number;
  /** 1 while every frame may draw; 2 or 3 while frames come late and only every n-th draws */
  drawEvery: number;
}

const KEEP = 600;

declare global {
  interface Window {
    __induropPlotStats?: PlotStats;
  }
}

/** Counters that no benchmark reads (a panel of fixed rows needs some all the same). */
export function emptyStats(): PlotStats {
  return {
    frames: 0,
    draws: 0,
    frameTimes: [],
    frameIntervals: [],
    fps: 0,
    samples: 0,
    uiDropped: 0,
    points: 0,
    panels: 0,
    drawEvery: 1,
  };
}

export function plotStats(): PlotStats {
  const s = emptyStats();
  window.__induropPlotStats = s;
  return s;
}

function keep(a: number[], v: number): void {
  a.push(v);
  if (a.length > 2 * KEEP) a.splice(0, a.length - KEEP);
}

/** Counts one animation frame: its rAF time `ts`, the previous frame's, the ms of work it took. */
export function recordFrame(s: PlotStats, ts: number, last: number | null, workMs: number, drew: boolean): void {
  s.frames++;
  if (drew) s.draws++;
  keep(s.frameTimes, workMs);
  if (last !== null) keep(s.frameIntervals, ts - last);
  let sum = 0;
  let n = 0;
  for (let i = s.frameIntervals.length - 1; i >= 0 && sum < 1000; i--, n++) sum += s.frameIntervals[i];
  s.fps = sum > 0 ? (1000 * n) / sum : 0;
}

/** Whether an animation frame may draw: every frame while frames come on time; every second or
 * third one while they come late (the page or the machine is busy), so that the frame rate holds
 * and the plots only update a little less often. */
export class Pacer {
  private avg = 1000 / 60;
  private since = 1;
  /** the frames between two draws now (1: every frame) */
  every = 1;

  /** Call once per frame with the time since the previous one (null for the first). */
  mayDraw(interval: number | null): boolean {
    if (interval !== null) this.avg += 0.1 * (Math.min(interval, 100) - this.avg);
    // up as soon as frames come late, down only once they are back on time (no flapping)
    if (this.avg > 25) this.every = 3;
    else if (this.avg > 18.5) this.every = Math.max(this.every, 2);
    else if (this.avg < 17.2 && this.every > 1) {
      this.every--;
      this.avg = 18; // give the lighter pace a moment before judging it
    }
    return this.since >= this.every;
  }

  /** Call after the frame: whether it drew. */
  done(drew: boolean): void {
    this.since = drew ? 1 : this.since + 1;
  }
}
