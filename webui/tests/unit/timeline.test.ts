// timeline.test.ts -- the slot table (Table 3) and the geometry of one macro period (Figure 2)
// from GET /schedule and the modules' measured execution times.
import { describe, expect, it } from "vitest";
import { renderSlotTable } from "../../src/ops/slot-table-view";
import { buildSlotTable, buildTimeline, changedSlots, ticks, viewRange } from "../../src/ops/timeline";
import { renderTimeline } from "../../src/ops/timeline-svg";
import type { Schedule } from "../../src/ops/types";

// the paper's Figure 1 as irpd schedules it (Table 3)
const FIG1: Schedule = {
  basic_period_ns: 100_000,
  macro_period_ns: 500_000,
  slots: [
    { index: 0, offset_ns: 0, modules: ["cntr3", "cntr2", "cntr1", "cntr4"] },
    { index: 1, offset_ns: 100_000, modules: ["cntr3", "cntr2"] },
    { index: 2, offset_ns: 200_000, modules: ["cntr3", "cntr2"] },
    { index: 3, offset_ns: 300_000, modules: ["cntr3", "cntr2"] },
    { index: 4, offset_ns: 400_000, modules: ["cntr3", "cntr2"] },
  ],
  modules: [
    {
      name: "cntr1",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: 500_000,
      deadline_ns: 0,
      priority: 3,
      executor: "main",
    },
    {
      name: "cntr2",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: 100_000,
      deadline_ns: 0,
      priority: 2,
      executor: "main",
    },
    {
      name: "cntr3",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: 100_000,
      deadline_ns: 0,
      priority: 1,
      executor: "main",
    },
    {
      name: "cntr4",
      moduletype: "process",
      operationtype: "periodic",
      period_ns: 500_000,
      deadline_ns: 0,
      priority: 4,
      executor: "main",
    },
    {
      name: "visionEvt",
      moduletype: "process",
      operationtype: "sporadic",
      period_ns: 0,
      deadline_ns: 100_000_000,
      priority: 2,
      executor: "main",
    },
    {
      name: "event1",
      moduletype: "thread",
      operationtype: "sporadic",
      period_ns: 0,
      deadline_ns: 1_000_000,
      priority: 1,
      executor: "main",
    },
    {
      name: "nonReaTime",
      moduletype: "process",
      operationtype: "non-real",
      period_ns: 0,
      deadline_ns: 0,
      priority: 0,
      executor: "main",
    },
  ],
};

const exec = (p50: number, p99: number, max: number) => ({ count: 10, min: p50, max, mean: p50, p50, p99, p999: p99 });
const FIGURES: Parameters<typeof buildTimeline>[1] = [
  { name: "cntr1", runs: 10, exec_ns: exec(1_000, 2_000, 9_000), enabled: true, state: "running" },
  { name: "cntr2", runs: 10, exec_ns: exec(3_000, 5_000, 7_000), enabled: true, state: "running" },
  { name: "cntr3", runs: 10, exec_ns: exec(2_000, 4_000, 4_000), enabled: true, state: "running" },
  { name: "cntr4", runs: 10, exec_ns: exec(10_000, 30_000, 200_000), enabled: true, state: "running" },
  { name: "event1", runs: 0, exec_ns: exec(0, 0, 0), enabled: true, state: "running" },
  { name: "visionEvt", runs: 10, exec_ns: exec(3_000, 6_000, 8_000), enabled: true, state: "running" },
  { name: "nonReaTime", runs: 0, exec_ns: exec(0, 0, 0), enabled: true, state: "running" },
];

describe("slot table", () => {
  it("is Table 3: rows are slots with offsets, cells the modules in priority order", () => {
    const t = buildSlotTable(FIG1);
    expect(t.slots).toBe(5);
    expect(t.columns).toBe(4);
    expect(t.rows.map((r) => r.offsetNs)).toEqual([0, 100_000, 200_000, 300_000, 400_000]);
    expect(t.rows[0].cells.map((c) => c.name)).toEqual(["cntr3", "cntr2", "cntr1", "cntr4"]);
    expect(t.rows[0].cells[3]).toMatchObject({ moduletype: "process", priority: 4, period_ns: 500_000 });
    expect(t.outside.map((m) => m.name)).toEqual(["visionEvt", "event1", "nonReaTime"]);
  });

  it("keeps at most maxRows rows but counts every slot", () => {
    const t = buildSlotTable(FIG1, 2);
    expect(t.rows.length).toBe(2);
    expect(t.slots).toBe(5);
  });

  it("changed slots between two tables", () => {
    const after: Schedule = {
      ...FIG1,
      slots: FIG1.slots.map((s) => (s.index === 0 ? { ...s, modules: ["cntr3", "cntr2", "cntr1"] } : s)),
    };
    expect([...changedSlots(buildSlotTable(FIG1), buildSlotTable(after))]).toEqual([0]);
    const shorter: Schedule = { ...FIG1, slots: FIG1.slots.slice(0, 1) };
    expect([...changedSlots(buildSlotTable(FIG1), buildSlotTable(shorter))]).toEqual([1, 2, 3, 4]);
  });

  it("renders with a row per slot and the macro period spanning them", () => {
    const el = renderSlotTable(buildSlotTable(FIG1), { testid: "slot-table" });
    const table = el.querySelector("[data-testid=slot-table]")!;
    expect(table.querySelectorAll("tbody tr").length).toBe(5);
    expect(table.querySelector("tr[data-slot='0']")!.textContent).toContain("cntr3cntr2cntr1cntr4");
    expect(table.querySelector(".slot-macro")!.getAttribute("rowspan")).toBe("5");
    expect(table.querySelector(".slot-macro")!.textContent).toBe("repeat the 5 basic periods every 500 µs");
    expect(el.querySelector("[data-testid=slot-table-outside]")!.textContent).toContain("event1");
  });
});

describe("timeline", () => {
  const tl = buildTimeline(FIG1, FIGURES);
  const main = tl.lanes[0];

  it("one lane per executor", () => {
    expect(tl.lanes.map((l) => l.executor)).toEqual(["main"]);
    expect(tl.slots).toBe(5);
    expect(main.nonReal).toEqual(["nonReaTime"]);
  });

  it("slot 0: the periodic modules in run order, stacked by p99, then the sporadic ones by priority", () => {
    const s0 = main.boxes.filter((b) => b.slot === 0);
    expect(s0.map((b) => [b.module, b.kind, b.start])).toEqual([
      ["cntr3", "periodic", 0],
      ["cntr2", "periodic", 4_000],
      ["cntr1", "periodic", 9_000],
      ["cntr4", "periodic", 11_000],
      ["event1", "sporadic", 41_000],
      ["visionEvt", "sporadic", 41_000],
    ]);
    expect(s0[3]).toMatchObject({ p50: 10_000, p99: 30_000, max: 200_000, measured: true, overflow: false });
    expect(s0[4]).toMatchObject({ measured: false, p99: 0 });
  });

  it("the time left over is where non-real work runs", () => {
    expect(main.idle[0]).toEqual({ slot: 0, start: 47_000, end: 100_000 });
    expect(main.idle[1]).toEqual({ slot: 1, start: 100_000 + 15_000, end: 200_000 });
    expect(main.busiestNs).toBe(47_000);
  });

  it("a slot that runs past its end is marked, and has no time left over", () => {
    const slow = FIGURES.map((f) => (f.name === "cntr4" ? { ...f, exec_ns: exec(80_000, 95_000, 99_000) } : f));
    const t = buildTimeline(FIG1, slow);
    const cntr4 = t.lanes[0].boxes.find((b) => b.module === "cntr4")!;
    expect(cntr4.overflow).toBe(true);
    expect(t.lanes[0].idle.find((i) => i.slot === 0)).toBeUndefined();
  });

  it("a disabled module takes no time", () => {
    const off = FIGURES.map((f) => (f.name === "cntr3" ? { ...f, enabled: false, state: "disabled" as const } : f));
    const b = buildTimeline(FIG1, off).lanes[0].boxes;
    expect(b[0]).toMatchObject({ module: "cntr3", p99: 0, measured: false });
    expect(b[1]).toMatchObject({ module: "cntr2", start: 0 });
  });

  it("a module on its own executor gets its own lane with the same slots", () => {
    const two: Schedule = {
      ...FIG1,
      modules: FIG1.modules.map((m) => (m.name === "cntr2" ? { ...m, executor: "fast" } : m)),
    };
    const t = buildTimeline(two, FIGURES);
    expect(t.lanes.map((l) => l.executor)).toEqual(["main", "fast"]);
    expect(t.lanes[1].boxes.map((b) => [b.module, b.slot, b.start])).toEqual(
      [0, 1, 2, 3, 4].map((s) => ["cntr2", s, s * 100_000]),
    );
    expect(t.lanes[0].boxes.filter((b) => b.slot === 1).map((b) => b.module)).toEqual(["cntr3", "event1", "visionEvt"]);
  });

  it("view ranges: the macro period, one slot, the busy part of a slot", () => {
    expect(viewRange(tl, null, false)).toEqual([0, 500_000]);
    expect(viewRange(tl, 2, false)).toEqual([200_000, 300_000]);
    expect(viewRange(tl, 2, true)).toEqual([200_000, 200_000 + 47_000 * 1.25]);
  });

  it("ticks are round", () => {
    expect(ticks(0, 500_000, 5)).toEqual([0, 100_000, 200_000, 300_000, 400_000, 500_000]);
    expect(ticks(200_000, 258_750, 6)).toEqual([200_000, 210_000, 220_000, 230_000, 240_000, 250_000]);
  });

  it("renders lanes, slot boundaries and boxes as SVG", () => {
    const svg = renderTimeline(tl, 0, 500_000, { width: 1000 });
    expect(svg.querySelectorAll(".tl-lane").length).toBe(1);
    expect(svg.querySelectorAll(".tl-boundary").length).toBe(6);
    expect(svg.querySelectorAll(".tl-box.tl-periodic").length).toBe(4 + 4 * 2);
    expect(svg.querySelectorAll(".tl-box.tl-sporadic").length).toBe(10);
    expect(svg.querySelectorAll(".tl-idle").length).toBe(5);
    const zoomed = renderTimeline(tl, 100_000, 200_000, { width: 1000 });
    expect([...zoomed.querySelectorAll(".tl-box")].every((b) => b.getAttribute("data-slot") === "1")).toBe(true);
  });
});
