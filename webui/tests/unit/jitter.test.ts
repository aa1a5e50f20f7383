// jitter.test.ts -- the jitter page's "jitter per 1 s interval" charts: their x axis spans the
// seconds the page has polled and is labelled with clock times, from the first interval on.  The
// page runs as in the browser (its own uPlot charts, GET /jitter/histograms answered here, polls
// on fake timers); canvases get a 2D context that records the text drawn on it.
import "./dom-shims";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import type { Api } from "../../src/api/client";
import type { components } from "../../src/api/schema";
import type { AppContext } from "../../src/app/context";
import { wallClockRange } from "../../src/plot/timeaxis";
import { charts } from "./kept-charts";

type Histograms = components["schemas"]["Histograms"];

// the charts the page makes are kept to look at their scales (dom-shims.ts gives uPlot what jsdom lacks)
vi.mock("uplot", async (original) => (await import("./kept-charts")).keepCharts(original));

const { jitterPage } = await import("../../src/pages/jitter");

/** Every canvas's 2D context: draws nothing, keeps the text drawn on it. */
const texts = new WeakMap<HTMLCanvasElement, string[]>();
function stubCanvas(): void {
  vi.spyOn(HTMLCanvasElement.prototype, "getContext").mockImplementation(function (this: HTMLCanvasElement) {
    const drawn: string[] = texts.get(this) ?? [];
    texts.set(this, drawn);
    const ctx: Record<string | symbol, unknown> = {
      canvas: this,
      fillText: (s: string) => drawn.push(s),
      measureText: (s: string) => ({ width: 6 * s.length, actualBoundingBoxAscent: 8, actualBoundingBoxDescent: 2 }),
      getImageData: () => ({ data: new Uint8ClampedArray(4) }),
      createLinearGradient: () => ({ addColorStop() {} }),
    };
    return new Proxy(ctx, {
      get: (t, k) => (k in t ? t[k] : () => {}),
      set: (t, k, v) => {
        t[k] = v;
        return true;
      },
    }) as never;
  });
}

/** One record as GET /jitter/histograms gives it, `runs` runs in, jitter 1..runs µs. */
function record(runs: number): Histograms["records"][number] {
  const h = { count: runs, min: 1000, max: runs * 1000, buckets: [{ low_ns: 1000, width_ns: 1000, count: runs }] };
  return {
    name: "Robot",
    kind: "module",
    executor: "main",
    runs,
    overruns: 0,
    missed: 0,
    skipped: 0,
    errors: 0,
    jitter_ns: h,
    latency_ns: h,
    exec_ns: h,
  };
}

function context(): AppContext {
  let polls = 0;
  const GET = async () => {
    polls++;
    const data: Histograms = { cycles: polls * 1000, time_ns: polls * 1e9, records: [record(polls * 100)] };
    return { data, response: new Response(null, { status: 200 }) };
  };
  return { api: { GET } as unknown as Api, can: () => true, notify() {} } as unknown as AppContext;
}

const MONTHS = /\b(Jan|Feb|Mar|Apr|May|Jun|Jul|Aug|Sep|Oct|Nov|Dec)\b/;
const T0 = Date.UTC(2026, 10, 26, 6, 0, 0); // the first poll, ms

describe("the jitter page's time charts", () => {
  let root: HTMLElement;
  let unmount: () => void;
  beforeEach(() => {
    vi.useFakeTimers({ now: T0, toFake: ["setTimeout", "clearTimeout", "Date"] });
    stubCanvas();
    charts.length = 0;
    root = document.createElement("div");
    document.body.appendChild(root);
    unmount = jitterPage(root, context());
  });
  afterEach(() => {
    unmount();
    root.remove();
    vi.useRealTimers();
    vi.restoreAllMocks();
  });

  /** The text drawn on the time chart's canvas: its axes' labels. */
  const labels = () => texts.get(root.querySelector<HTMLCanvasElement>("[data-testid=jitter-time-Robot] canvas")!)!;

  it("span seconds ending at the newest poll and are labelled with clock times from the first interval", async () => {
    await vi.advanceTimersByTimeAsync(1000); // the first poll sets the baseline, the second gives an interval
    expect(charts).toHaveLength(1);
    const x = charts[0].scales.x;
    expect(x.max).toBe(T0 / 1000 + 1);
    expect(x.max! - x.min!).toBe(30);
    expect(labels().filter((s) => MONTHS.test(s))).toEqual([]);
    expect(labels().some((s) => /:\d\d/.test(s))).toBe(true);

    await vi.advanceTimersByTimeAsync(60_000); // a minute on: from the first interval to the newest
    expect([x.min, x.max]).toEqual([T0 / 1000 + 1, T0 / 1000 + 61]);
    expect(labels().filter((s) => MONTHS.test(s))).toEqual([]);
  });
});

describe("wallClockRange", () => {
  it("is null without samples, minSpan wide at first, then from the first sample to the newest", () => {
    expect(wallClockRange([], 30)).toEqual([null, null]);
    expect(wallClockRange([100], 30)).toEqual([70, 100]);
    expect(wallClockRange([100, 101, 102], 30)).toEqual([72, 102]);
    expect(wallClockRange([100, 150], 30)).toEqual([100, 150]);
  });
});
