// module-table.test.ts -- the modules table keeps the operator's edits while its figures refresh,
// and a viewer gets no edit controls.
import { describe, expect, it } from "vitest";
import { ModuleTable } from "../../src/ops/module-table";
import type { ModuleInfo } from "../../src/ops/types";

const pct = (p99: number, max = p99) => ({ count: 1, min: 0, max, mean: 0, p50: 0, p99, p999: p99 });
const mod = (name: string, over: Partial<ModuleInfo> = {}): ModuleInfo => ({
  name,
  executor: "main",
  kind: "module",
  period_ns: 10_000_000,
  runs: 10,
  jitter_ns: pct(5_000),
  latency_ns: pct(0),
  exec_ns: pct(20_000, 90_000),
  overruns: 0,
  missed: 0,
  skipped: 0,
  errors: 0,
  stats_dropped: 0,
  state: "running",
  priority: 2,
  budget_ns: 0,
  moduletype: "thread",
  operationtype: "periodic",
  deadline_ns: 0,
  enabled: true,
  file: `lib/${name}.so`,
  sha256: "",
  properties: {},
  ...over,
});

function type(input: HTMLInputElement, value: string): void {
  input.value = value;
  input.dispatchEvent(new Event("input"));
}

describe("ModuleTable", () => {
  it("one row per module, with figures and units", () => {
    const t = new ModuleTable(false, () => {});
    t.update([
      mod("main"),
      mod("drivesim", { operationtype: "non-real", moduletype: "process", period_ns: 0, runs: 0 }),
    ]);
    const row = t.element.querySelector("[data-testid=module-row-main]")!;
    const cell = (k: string) => row.querySelector(`[data-col=${k}]`)!.textContent;
    expect(cell("period")).toBe("10 ms");
    expect(cell("jitter")).toBe("5 µs");
    expect(cell("execMax")).toBe("90 µs");
    expect(cell("state")).toBe("running");
    expect(t.element.querySelector("[data-testid=module-row-drivesim] [data-col=period]")!.textContent).toBe("–");
  });

  it("a viewer gets no inputs", () => {
    const t = new ModuleTable(false, () => {});
    t.update([mod("main")]);
    expect(t.element.querySelectorAll("input").length).toBe(0);
  });

  it("keeps typed values across refreshes; an edit equal to what runs is no edit", () => {
    let edits = 0;
    const t = new ModuleTable(true, () => edits++);
    t.update([mod("main"), mod("Robot", { priority: 1 })]);
    const period = t.element.querySelector<HTMLInputElement>("[data-testid=edit-period-main]")!;
    const prio = t.element.querySelector<HTMLInputElement>("[data-testid=edit-priority-Robot]")!;
    const enabled = t.element.querySelector<HTMLInputElement>("[data-testid=edit-enabled-main]")!;
    expect(period.value).toBe("10ms");
    expect(prio.value).toBe("1");
    expect(enabled.checked).toBe(true);

    type(period, "5ms");
    type(prio, "7");
    enabled.checked = false;
    enabled.dispatchEvent(new Event("change"));
    expect(edits).toBe(3);
    expect(Object.fromEntries(t.edits)).toEqual({ main: { period: "5ms", enabled: false }, Robot: { priority: "7" } });

    // a refresh with new figures and a changed running priority of another module
    t.update([mod("main", { runs: 99 }), mod("Robot", { priority: 1, runs: 99 })]);
    expect(period.value).toBe("5ms");
    expect(prio.value).toBe("7");
    expect(enabled.checked).toBe(false);
    expect(t.element.querySelector("[data-testid=module-row-main] [data-col=runs]")!.textContent).toBe("99");
    expect(t.element.querySelector("[data-testid=module-row-main] .ops-was")!.textContent).toBe("now 10 ms");

    type(period, "10 ms"); // back to what runs
    expect(t.edits.get("main")).toEqual({ enabled: false });

    t.discard();
    expect(t.edits.size).toBe(0);
    expect(period.value).toBe("10ms");
    expect(prio.value).toBe("1");
    expect(enabled.checked).toBe(true);
  });

  it("untouched inputs follow what runs (after an applied change)", () => {
    const t = new ModuleTable(true, () => {});
    t.update([mod("main")]);
    t.update([mod("main", { period_ns: 5_000_000, priority: 4 })]);
    expect(t.element.querySelector<HTMLInputElement>("[data-testid=edit-period-main]")!.value).toBe("5ms");
    expect(t.element.querySelector<HTMLInputElement>("[data-testid=edit-priority-main]")!.value).toBe("4");
  });

  it("marks inputs by the issues that name them", () => {
    const t = new ModuleTable(true, () => {});
    t.update([mod("main")]);
    t.mark([
      { level: "error", module: "main", field: "period", message: "bad" },
      { level: "warning", module: "main", field: "priority", message: "dup" },
    ]);
    const period = t.element.querySelector<HTMLInputElement>("[data-testid=edit-period-main]")!;
    expect(period.classList.contains("invalid")).toBe(true);
    expect(period.title).toBe("bad");
    expect(t.element.querySelector("[data-testid=edit-priority-main]")!.classList.contains("warning")).toBe(true);
  });

  it("rebuilds rows when the set's modules change, keeping edits by name", () => {
    const t = new ModuleTable(true, () => {});
    t.update([mod("a"), mod("b")]);
    type(t.element.querySelector<HTMLInputElement>("[data-testid=edit-period-a]")!, "20ms");
    t.update([mod("a"), mod("c")]);
    expect(t.element.querySelector("[data-testid=module-row-b]")).toBeNull();
    expect(t.element.querySelector<HTMLInputElement>("[data-testid=edit-period-a]")!.value).toBe("20ms");
  });
});
