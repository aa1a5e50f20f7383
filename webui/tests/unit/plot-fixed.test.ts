// plot-fixed.test.ts -- the plot panel showing a fixed table of rows (the Scope page's shots):
// SampleRing.of holds exactly the rows; a sparse table's missing samples are drawn across (no gap)
// while a single shot's seq jump is a gap; the lines are drawn across undefined and lifted at null;
// the panel (its own uPlot chart) shows the rows on an x axis of seconds from the mark, in time
// and x–y mode, without the stream's controls.
import "./dom-shims";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import { charts } from "./kept-charts";

vi.mock("uplot", async (original) => (await import("./kept-charts")).keepCharts(original));

const { decimateRange, emptyDraw } = await import("../../src/plot/decimate");
const { drawLines } = await import("../../src/plot/lines");
const { PlotPanel } = await import("../../src/plot/panel");
const { SampleRing } = await import("../../src/plot/ring");
const { emptyStats } = await import("../../src/plot/stats");
type FixedRows = import("../../src/plot/ring").FixedRows;

const nan = Number.NaN;

function rows(over: Partial<FixedRows> = {}): FixedRows {
  return {
    names: ["a", "b"],
    seq: [10, 11, 12, 13],
    t: [-0.002, -0.001, 0, 0.001],
    cols: [
      [1, 2, 3, 4],
      [5, nan, 7, 8],
    ],
    decimation: 1,
    sparse: false,
    marks: [{ x: 0, label: "trigger" }],
    ...over,
  };
}

describe("SampleRing.of", () => {
  it("holds exactly the rows given, in order", () => {
    const r = SampleRing.of(rows());
    expect([r.length, r.capacity, r.channels, r.total, r.nextSeq]).toEqual([4, 4, 2, 4, 14]);
    expect([0, 1, 2, 3].map((i) => [r.seqAt(i), r.tAt(i), r.valueAt(0, i)])).toEqual([
      [10, -0.002, 1],
      [11, -0.001, 2],
      [12, 0, 3],
      [13, 0.001, 4],
    ]);
    expect(r.range(-0.001, 0)).toEqual([1, 3]);
    expect(SampleRing.of(rows({ sparse: true })).copy().sparse).toBe(true);
    expect(SampleRing.of(rows({ seq: [], t: [], cols: [[], []] })).length).toBe(0);
  });
});

describe("decimating fixed rows", () => {
  it("draws a single shot's seq jump as a gap and its NaN as null", () => {
    const d = emptyDraw(2);
    decimateRange(SampleRing.of(rows({ seq: [10, 11, 13, 14] })), 0, 4, 1, 0, d);
    expect(d.x).toEqual([-0.002, -0.001, -0.0005, 0, 0.001]); // a null point between 11 and 13
    expect(d.ys[0]).toEqual([1, 2, null, 3, 4]);
    expect(d.ys[1]).toEqual([5, null, null, 7, 8]);
  });

  it("leaves a sparse table's missing samples undefined (drawn across) and checks no seq step", () => {
    const d = emptyDraw(2);
    decimateRange(SampleRing.of(rows({ sparse: true, seq: [-2, -1, 0, 5] })), 0, 4, 1, 0, d);
    expect(d.x).toEqual([-0.002, -0.001, 0, 0.001]);
    expect(d.ys[1]).toEqual([5, undefined, 7, 8]);
  });
});

describe("drawLines", () => {
  it("draws across undefined and lifts the pen at null", () => {
    const calls: string[] = [];
    const ctx = new Proxy(
      {},
      {
        get: (_t, k) => (k === "moveTo" || k === "lineTo" ? (x: number) => calls.push(`${String(k)} ${x}`) : () => {}),
      },
    );
    const u = {
      ctx,
      bbox: { left: 0, top: 0, width: 100, height: 100 },
      data: [
        [0, 1, 2, 3, 4, 5],
        [1, undefined, 1, null, 1, 1],
      ],
      scales: { x: { min: 0, max: 5 }, y: { min: 0, max: 2 } },
      series: [{}, { show: true }],
    };
    drawLines(u as never);
    expect(calls).toEqual(["moveTo 0", "lineTo 40", "moveTo 80", "lineTo 100"]);
  });
});

describe("a panel of fixed rows", () => {
  let panel: InstanceType<typeof PlotPanel>;
  beforeEach(() => {
    charts.length = 0;
    vi.spyOn(HTMLCanvasElement.prototype, "getContext").mockImplementation(
      () => new Proxy({}, { get: (_t, k) => (k === "measureText" ? () => ({ width: 10 }) : () => {}) }) as never,
    );
    panel = new PlotPanel(
      1,
      { paths: [], mode: "time", windowS: 10, xy: [null, null] },
      {
        stream: null,
        stats: emptyStats(),
        clock: { offset: 1e9 }, // never applied to fixed rows
        known: () => true,
        notify() {},
        changed() {},
        remove() {},
        activate() {},
      },
    );
    document.body.appendChild(panel.el);
  });
  afterEach(() => {
    panel.destroy();
    vi.restoreAllMocks();
  });

  it("has none of the stream's controls and shows its rows on seconds from the mark", () => {
    const q = (id: string) => panel.el.querySelector(`[data-testid=${id}]`);
    expect(["window", "pause", "csv", "remove-panel", "panel-add"].map(q)).toEqual([null, null, null, null, null]);
    expect(q("mode")).not.toBeNull();
    panel.showRows(rows());
    expect(panel.frame()).toBe(8); // 4 rows × 2 series, every row (fewer than pixels)
    const chart = charts[charts.length - 1];
    expect(chart.scales.x.time).toBe(false);
    expect(chart.data[0]).toEqual([-0.002, -0.001, 0, 0.001]);
    expect(chart.data[2]).toEqual([5, null, 7, 8]);
    expect([...panel.el.querySelectorAll(".chip")].map((c) => c.textContent)).toEqual(["a×", "b×"]);
    expect(panel.rows?.length).toBe(4);
    expect(panel.frame()).toBe(-1); // nothing changed: nothing drawn
  });

  it("keeps the rows when a series is removed, and shows x–y of two of them", () => {
    panel.showRows(rows());
    panel.el.querySelector<HTMLButtonElement>(".chip button[data-path=a]")!.click();
    panel.frame();
    expect(charts[charts.length - 1].data.slice(1)).toEqual([[5, null, 7, 8]]);
    panel.showRows(rows());
    panel.setView("xy", ["b", "a"]);
    expect(panel.cfg.xy).toEqual(["b", "a"]);
    expect(panel.el.querySelector("[data-testid=xy-canvas]")).not.toBeNull();
    expect(panel.frame()).toBeGreaterThan(0);
    panel.setView("time", ["nope", "a"]);
    expect(panel.cfg.xy).toEqual([null, "a"]);
  });
});
