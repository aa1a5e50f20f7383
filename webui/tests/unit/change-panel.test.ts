// change-panel.test.ts -- pending module changes: a debounced dry run whose answer decides, then
// Apply (preview: the slot table before and after), then Confirm (the swap report).
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import type { AppContext } from "../../src/app/context";
import { ChangePanel } from "../../src/ops/change-panel";
import { ModuleTable } from "../../src/ops/module-table";
import type { ModuleInfo, Schedule } from "../../src/ops/types";

const pct = (p99: number) => ({ count: 1, min: 0, max: p99, mean: 0, p50: p99 / 2, p99, p999: p99 });
const mod = (name: string, period_ns: number, priority: number): ModuleInfo => ({
  name,
  executor: "main",
  kind: "module",
  period_ns,
  runs: 10,
  jitter_ns: pct(0),
  latency_ns: pct(0),
  exec_ns: pct(1_000),
  overruns: 0,
  missed: 0,
  skipped: 0,
  errors: 0,
  stats_dropped: 0,
  state: "running",
  priority,
  budget_ns: 0,
  moduletype: "thread",
  operationtype: "periodic",
  deadline_ns: 0,
  enabled: true,
  file: `lib/${name}.so`,
  sha256: "",
  properties: {},
});
const sched = (macro: number): Schedule => ({
  basic_period_ns: 100_000,
  macro_period_ns: macro,
  slots: Array.from({ length: macro / 100_000 }, (_, i) => ({
    index: i,
    offset_ns: i * 100_000,
    modules: i === 0 ? ["a", "b"] : ["a"],
  })),
  modules: [
    {
      name: "a",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: 100_000,
      deadline_ns: 0,
      priority: 1,
      executor: "main",
    },
    {
      name: "b",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: macro,
      deadline_ns: 0,
      priority: 2,
      executor: "main",
    },
  ],
});

type Answer = { status: number; body: unknown };

function fakeCtx(answer: (body: { changes: unknown[]; dry_run: boolean }) => Answer) {
  const calls: { changes: unknown[]; dry_run: boolean }[] = [];
  const notes: string[] = [];
  const ctx = {
    api: {
      POST: async (_path: string, opts: { body: { changes: unknown[]; dry_run: boolean } }) => {
        calls.push(opts.body);
        const a = answer(opts.body);
        const ok = a.status < 300;
        return {
          data: ok ? a.body : undefined,
          error: ok ? undefined : a.body,
          response: new Response(null, { status: a.status }),
        };
      },
    },
    session: { name: "op", role: "operator", csrf: "c" },
    can: () => true,
    notify: (m: string) => notes.push(m),
  } as unknown as AppContext;
  return { ctx, calls, notes };
}

const flush = async () => {
  for (let i = 0; i < 5; i++) await Promise.resolve();
};

function setup(answer: (body: { changes: unknown[]; dry_run: boolean }) => Answer) {
  const f = fakeCtx(answer);
  let panel: ChangePanel | null = null;
  const reports: string[] = [];
  const table = new ModuleTable(true, () => panel?.refresh());
  panel = new ChangePanel(f.ctx, table, (title) => reports.push(title));
  document.body.replaceChildren(table.element, panel.element);
  table.update([mod("a", 100_000, 1), mod("b", 500_000, 2)]);
  panel.refresh();
  const q = <T extends Element = HTMLElement>(id: string) => document.querySelector<T>(`[data-testid=${id}]`)!;
  const type = (id: string, v: string) => {
    const i = q<HTMLInputElement>(id);
    i.value = v;
    i.dispatchEvent(new Event("input"));
  };
  return { ...f, panel, table, q, type, reports };
}

const ACCEPT = (b: { dry_run: boolean }): Answer => ({
  status: 200,
  body: {
    dry_run: b.dry_run,
    before: sched(500_000),
    after: sched(1_000_000),
    utilization: 0.25,
    warnings: [],
    report: b.dry_run
      ? null
      : {
          kept: ["a", "b"],
          started: [],
          stopped: [],
          swap_cycle: 42,
          missed_periods: 0,
          request_to_swap_ns: 1_000_000,
        },
  },
});

describe("ChangePanel", () => {
  beforeEach(() => vi.useFakeTimers());
  afterEach(() => vi.useRealTimers());

  it("debounces the dry run while typing, and Apply waits for its answer", async () => {
    const s = setup(ACCEPT);
    s.type("edit-period-b", "1");
    await vi.advanceTimersByTimeAsync(100);
    s.type("edit-period-b", "1m");
    await vi.advanceTimersByTimeAsync(100);
    s.type("edit-period-b", "1ms");
    expect(s.q<HTMLButtonElement>("apply").disabled).toBe(true);
    expect(s.q("dry-run").textContent).toMatch(/checking/);
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    // "1" (1 ns) is below the period's own execution time but complete; "1m" does not parse: only the last is asked once settled
    expect(s.calls.map((c) => c.changes)).toEqual([[{ name: "b", period_ns: 1_000_000 }]]);
    expect(s.q("dry-run").textContent).toMatch(/accepted/);
    expect(s.q<HTMLButtonElement>("apply").disabled).toBe(false);
  });

  it("Apply shows old and new slot tables; Confirm applies and reports", async () => {
    const s = setup(ACCEPT);
    s.type("edit-period-b", "1ms");
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    s.q<HTMLButtonElement>("apply").click();
    await flush();
    expect(s.q("preview").hidden).toBe(false);
    expect(s.q("preview-before").querySelectorAll("tbody tr").length).toBe(5);
    expect(s.q("preview-after").querySelectorAll("tbody tr").length).toBe(10);
    expect(s.q("preview-after").querySelectorAll("tr.changed").length).toBe(5);
    expect(s.q("preview-changes").textContent).toContain("period 500 µs → 1 ms");
    s.q<HTMLButtonElement>("confirm").click();
    await flush();
    expect(s.calls.at(-1)).toEqual({ changes: [{ name: "b", period_ns: 1_000_000 }], dry_run: false });
    expect(s.reports).toEqual(["Module changes applied (b)"]);
    expect(s.q("preview").hidden).toBe(true);
    expect(s.table.edits.size).toBe(0);
  });

  it("a refusal is authoritative: Apply stays off and the reason is shown", async () => {
    const s = setup(() => ({ status: 409, body: { detail: "module 'b': the basic period would be 1 µs" } }));
    s.type("edit-period-b", "300us");
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    expect(s.q("dry-run").textContent).toBe(
      "Server check (dry run): refused — module 'b': the basic period would be 1 µs",
    );
    expect(s.q<HTMLButtonElement>("apply").disabled).toBe(true);
  });

  it("a failure to answer offers a retry", async () => {
    let fail = true;
    const s = setup((b) => (fail ? { status: 500, body: "Internal Server Error" } : ACCEPT(b)));
    s.type("edit-priority-a", "3");
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    expect(s.q("dry-run").textContent).toMatch(/failed: HTTP 500/);
    fail = false;
    s.q<HTMLButtonElement>("dry-run-retry").click();
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    expect(s.q("dry-run").textContent).toMatch(/accepted/);
  });

  it("a failed dry run is asked again by itself on a later refresh", async () => {
    let fail = true;
    const s = setup((b) => (fail ? { status: 500, body: "Internal Server Error" } : ACCEPT(b)));
    s.type("edit-priority-a", "3");
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    fail = false;
    await vi.advanceTimersByTimeAsync(5_100);
    s.panel.refresh(); // the page refreshes every second
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    expect(s.calls.length).toBe(2);
    expect(s.q("dry-run").textContent).toMatch(/accepted/);
  });

  it("an edit after Apply closes the preview", async () => {
    const s = setup(ACCEPT);
    s.type("edit-period-b", "1ms");
    await vi.advanceTimersByTimeAsync(500);
    await flush();
    s.q<HTMLButtonElement>("apply").click();
    await flush();
    expect(s.q("preview").hidden).toBe(false);
    s.type("edit-priority-a", "5");
    expect(s.q("preview").hidden).toBe(true);
  });
});
