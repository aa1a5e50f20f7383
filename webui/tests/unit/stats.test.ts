// stats.test.ts -- the plot page's frame statistics and its drawing pace.
import { describe, expect, it } from "vitest";
import { Pacer, plotStats, recordFrame } from "../../src/plot/stats";

describe("recordFrame", () => {
  it("counts frames and draws, keeps recent times, and gives the rate over the last second", () => {
    const s = plotStats();
    expect(window.__induropPlotStats).toBe(s);
    let last: number | null = null;
    for (let i = 0; i < 120; i++) {
      const ts = i * 20;
      recordFrame(s, ts, last, 2, i % 2 === 0);
      last = ts;
    }
    expect(s.frames).toBe(120);
    expect(s.draws).toBe(60);
    expect(s.frameIntervals.length).toBe(119);
    expect(s.frameTimes.every((t) => t === 2)).toBe(true);
    expect(s.fps).toBeCloseTo(50, 5);
  });
});

describe("Pacer", () => {
  const run = (p: Pacer, interval: number, frames: number) => {
    let draws = 0;
    for (let i = 0; i < frames; i++) {
      const may = p.mayDraw(interval);
      p.done(may);
      if (may) draws++;
    }
    return draws;
  };

  it("lets every frame draw while frames come on time", () => {
    expect(run(new Pacer(), 16.7, 60)).toBe(60);
  });

  it("draws every second or third frame while they come late, and recovers", () => {
    const p = new Pacer();
    run(p, 22, 60);
    expect(p.every).toBe(2);
    expect(run(p, 22, 60)).toBe(30);
    run(p, 40, 60);
    expect(p.every).toBe(3);
    run(p, 16.7, 200);
    expect(p.every).toBe(1);
  });

  it("does not count a frame with nothing to draw as a draw", () => {
    const p = new Pacer();
    run(p, 22, 60);
    expect(p.mayDraw(22)).toBe(true);
    p.done(false); // nothing new: the next frame may still draw
    expect(p.mayDraw(22)).toBe(true);
  });
});
