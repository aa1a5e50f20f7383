// validate.test.ts -- the client's checks of pending module edits: periods, the new GCD and LCM,
// estimated utilization per executor, duplicate priorities.
import { describe, expect, it } from "vitest";
import {
  MAX_CHANGES,
  MAX_SLOTS,
  MIN_BASIC_PERIOD_NS,
  PRIORITY_MAX,
  PRIORITY_MIN,
  UTILIZATION_ERROR,
  UTILIZATION_WARNING,
} from "../../src/api/protocol";
import type { ModuleInfo } from "../../src/ops/types";
import {
  checkEdits,
  DEFAULT_LIMITS,
  duplicatePriorities,
  type Edit,
  executorLoads,
  gcd,
  lcm,
  parsePriority,
} from "../../src/ops/validate";

const pct = (p50: number, p99: number, max = p99) => ({ count: 100, min: 0, max, mean: p50, p50, p99, p999: p99 });

function mod(name: string, over: Partial<ModuleInfo> = {}): ModuleInfo {
  return {
    name,
    executor: "main",
    kind: "module",
    period_ns: 100_000,
    runs: 100,
    jitter_ns: pct(0, 0),
    latency_ns: pct(0, 0),
    exec_ns: pct(1_000, 2_000, 5_000),
    overruns: 0,
    missed: 0,
    skipped: 0,
    errors: 0,
    stats_dropped: 0,
    state: "running",
    priority: 1,
    budget_ns: 0,
    moduletype: "thread",
    operationtype: "periodic",
    deadline_ns: 0,
    enabled: true,
    file: `lib/${name}.so`,
    sha256: "",
    properties: {},
    ...over,
  };
}

// the paper's Figure 1: cntr1 500 µs, cntr2 100 µs, cntr3 100 µs, cntr4 500 µs, two sporadic, one non-real
const FIG1 = [
  mod("cntr1", { period_ns: 500_000, priority: 3 }),
  mod("cntr2", { period_ns: 100_000, priority: 2 }),
  mod("cntr3", { period_ns: 100_000, priority: 1 }),
  mod("cntr4", { period_ns: 500_000, priority: 4, moduletype: "process" }),
  mod("event1", { operationtype: "sporadic", period_ns: 0, priority: 1, deadline_ns: 1_000_000 }),
  mod("visionEvt", { operationtype: "sporadic", period_ns: 0, priority: 2, moduletype: "process" }),
  mod("nonReaTime", { operationtype: "non-real", period_ns: 0, priority: 0, runs: 0 }),
];

const edits = (e: Record<string, Edit>) => new Map(Object.entries(e));
const messages = (c: ReturnType<typeof checkEdits>, level: string) =>
  c.issues.filter((i) => i.level === level).map((i) => i.message);

describe("gcd and lcm", () => {
  it("of periods", () => {
    expect([500_000, 100_000, 100_000, 500_000].reduce(gcd)).toBe(100_000);
    expect([500_000, 100_000, 300_000].reduce(lcm)).toBe(1_500_000);
    expect(lcm(2 ** 52 + 1, 2 ** 52 - 1)).toBe(Infinity);
  });
});

describe("checkEdits", () => {
  it("no edits: no changes, the running basic and macro period", () => {
    const c = checkEdits(FIG1, new Map());
    expect(c.changes).toEqual([]);
    expect(c.basicNs).toBe(100_000);
    expect(c.macroNs).toBe(500_000);
    expect(c.slots).toBe(5);
    expect(messages(c, "error")).toEqual([]);
  });

  it("turns typed fields into changes, leaving out what equals the running value", () => {
    const c = checkEdits(
      FIG1,
      edits({ cntr1: { period: "1ms", priority: "3" }, cntr2: { enabled: false }, cntr3: { period: "100us" } }),
    );
    expect(c.complete).toBe(true);
    expect(c.changes).toEqual([
      { name: "cntr1", period_ns: 1_000_000 },
      { name: "cntr2", enabled: false },
    ]);
    expect(c.macroNs).toBe(1_000_000);
    expect(c.slots).toBe(10);
    expect(messages(c, "info")).toContain("macro period 500 µs → 1 ms (10 slots)");
  });

  it("a period that does not parse makes the edits incomplete", () => {
    const c = checkEdits(FIG1, edits({ cntr1: { period: "fast" } }));
    expect(c.complete).toBe(false);
    expect(c.issues[0]).toMatchObject({ level: "error", module: "cntr1", field: "period" });
  });

  it("a period below the minimum basic period", () => {
    const c = checkEdits(FIG1, edits({ cntr2: { period: "20us" } }), { ...DEFAULT_LIMITS, minBasicNs: 50_000 });
    const e = c.issues.filter((i) => i.level === "error");
    expect(e.some((i) => i.module === "cntr2" && /below the minimum basic period 50 µs/.test(i.message))).toBe(true);
  });

  it("a new GCD below the minimum, though each period is above it", () => {
    // 150 µs and 100 µs: GCD 50 µs; with a 60 µs minimum it is refused
    const c = checkEdits(FIG1, edits({ cntr1: { period: "150us" } }), { ...DEFAULT_LIMITS, minBasicNs: 60_000 });
    expect(c.basicNs).toBe(50_000);
    expect(
      messages(c, "error").some((m) =>
        /new basic period \(GCD of the periods\) would be 50 µs, below the minimum 60 µs/.test(m),
      ),
    ).toBe(true);
  });

  it("a GCD change within the limits is information", () => {
    const c = checkEdits(FIG1, edits({ cntr1: { period: "150us" } }));
    expect(messages(c, "error")).toEqual([]);
    expect(messages(c, "info")).toContain("basic period 100 µs → 50 µs");
  });

  it("too many slots (non-harmonic periods)", () => {
    const c = checkEdits(FIG1, edits({ cntr1: { period: "100003us" } }));
    expect(messages(c, "error").some((m) => /macro period .* basic periods; at most 100000/.test(m))).toBe(true);
  });

  it("a period shorter than the module's own execution time", () => {
    const mods = [mod("a", { period_ns: 1_000_000, exec_ns: pct(100_000, 300_000) })];
    const c = checkEdits(mods, edits({ a: { period: "200us" } }));
    expect(c.issues.some((i) => i.module === "a" && /shorter than its measured execution time/.test(i.message))).toBe(
      true,
    );
  });

  it("only periodic modules have a period", () => {
    const c = checkEdits(FIG1, edits({ event1: { period: "1ms" } }));
    expect(c.complete).toBe(false);
    expect(c.issues[0].message).toMatch(/sporadic: only periodic modules have a period/);
  });

  it("a module no longer in the set", () => {
    const c = checkEdits(FIG1, edits({ gone: { priority: "2" } }));
    expect(c.complete).toBe(false);
    expect(c.issues[0].message).toMatch(/no longer in the running set/);
  });

  it("priority must be a whole number in range", () => {
    expect(parsePriority("3")).toEqual({ ok: true, value: 3 });
    expect(parsePriority("-1").ok).toBe(false);
    expect(parsePriority("1.5").ok).toBe(false);
    expect(parsePriority("2000000").ok).toBe(false);
    const c = checkEdits(FIG1, edits({ cntr1: { priority: "x" } }));
    expect(c.issues[0]).toMatchObject({ level: "error", field: "priority" });
  });

  it("disabling every periodic module leaves the GCD (disabled ones keep their slots)", () => {
    const all = edits(
      Object.fromEntries(FIG1.filter((m) => m.operationtype === "periodic").map((m) => [m.name, { enabled: false }])),
    );
    const c = checkEdits(FIG1, all);
    expect(c.basicNs).toBe(100_000);
    expect(c.load.find((l) => l.executor === "main")!.fraction).toBe(0);
  });
});

describe("utilization", () => {
  it("Σ max(exec p99, budget) / period per executor, enabled periodic modules only", () => {
    const mods = [
      mod("a", { period_ns: 100_000, exec_ns: pct(10_000, 40_000) }), // 40 %
      mod("b", { period_ns: 200_000, exec_ns: pct(10_000, 20_000), budget_ns: 40_000 }), // 20 % (budget)
      mod("c", { period_ns: 100_000, exec_ns: pct(10_000, 50_000), enabled: false }), // disabled
      mod("d", { period_ns: 0, operationtype: "sporadic", exec_ns: pct(10_000, 90_000) }), // sporadic
      mod("e", { executor: "fast", period_ns: 100_000, exec_ns: pct(10_000, 10_000) }), // 10 % elsewhere
    ];
    const loads = executorLoads(mods);
    expect(loads.find((l) => l.executor === "main")!.fraction).toBeCloseTo(0.6);
    expect(loads.find((l) => l.executor === "fast")!.fraction).toBeCloseTo(0.1);
    expect(loads.every((l) => l.level === null)).toBe(true);
  });

  it("over 80 % is a warning, over 100 % an error", () => {
    const mods = [
      mod("a", { period_ns: 100_000, exec_ns: pct(10_000, 45_000) }),
      mod("b", { period_ns: 100_000, exec_ns: pct(10_000, 40_000), priority: 2 }),
    ];
    const warn = checkEdits(mods, new Map());
    expect(warn.load[0]).toMatchObject({ level: "warning" });
    expect(
      messages(warn, "warning").some((m) => /executor main: estimated utilization 85.0 % is over 80 %/.test(m)),
    ).toBe(true);
    const err = checkEdits(mods, edits({ b: { period: "60us" } }), { ...DEFAULT_LIMITS, minBasicNs: 10_000 });
    expect(err.load[0].level).toBe("error");
    expect(messages(err, "error").some((m) => /is over 100 %/.test(m))).toBe(true);
  });

  it("enabling a module counts it again", () => {
    const mods = [mod("a", { exec_ns: pct(10_000, 50_000), enabled: false })];
    expect(checkEdits(mods, new Map()).load[0].fraction).toBe(0);
    expect(checkEdits(mods, edits({ a: { enabled: true } })).load[0].fraction).toBeCloseTo(0.5);
  });
});

describe("duplicate priorities", () => {
  it("within one executor and operation type, every module marked", () => {
    const w = duplicatePriorities([
      { name: "a", executor: "main", operationtype: "periodic", priority: 2 },
      { name: "b", executor: "main", operationtype: "periodic", priority: 2 },
      { name: "c", executor: "io", operationtype: "periodic", priority: 2 },
      { name: "d", executor: "main", operationtype: "sporadic", priority: 2 },
      { name: "e", executor: "main", operationtype: "non-real", priority: 2 },
    ]);
    expect(w.map((i) => i.module)).toEqual(["a", "b"]);
    expect(w[0]).toMatchObject({ level: "warning", field: "priority" });
    expect(w[0].message).toMatch(/a, b \(periodic, executor main\) share priority 2/);
  });

  it("an edit that makes two priorities equal is flagged", () => {
    const c = checkEdits(FIG1, edits({ cntr1: { priority: "2" } }));
    expect(
      c.issues
        .filter((i) => i.level === "warning")
        .map((i) => i.module)
        .sort(),
    ).toEqual(["cntr1", "cntr2"]);
  });

  it("the paper's set has none (event1 and cntr3 share 1, but one is sporadic)", () => {
    expect(duplicatePriorities(FIG1)).toEqual([]);
  });
});

// The limits are irpd's (protocol/control.json, generated into src/api/protocol.ts): each is tried
// at its edge, on the side irpd accepts and on the side it refuses.
describe("irpd's limits at their edges", () => {
  const errors = (c: ReturnType<typeof checkEdits>) => messages(c, "error");

  it("priority: from PRIORITY_MIN to PRIORITY_MAX", () => {
    expect(parsePriority(String(PRIORITY_MIN))).toEqual({ ok: true, value: PRIORITY_MIN });
    expect(parsePriority(String(PRIORITY_MAX))).toEqual({ ok: true, value: PRIORITY_MAX });
    expect(parsePriority(String(PRIORITY_MIN - 1))).toMatchObject({
      ok: false,
      error: `priority ${PRIORITY_MIN - 1} is below ${PRIORITY_MIN}`,
    });
    expect(parsePriority(String(PRIORITY_MAX + 1))).toMatchObject({
      ok: false,
      error: `priority ${PRIORITY_MAX + 1} is above ${PRIORITY_MAX}`,
    });
  });

  it("a period of exactly the minimum basic period, and one nanosecond less", () => {
    const one = [mod("a")];
    expect(errors(checkEdits(one, edits({ a: { period: `${MIN_BASIC_PERIOD_NS}ns` } })))).toEqual([]);
    const below = checkEdits(one, edits({ a: { period: `${MIN_BASIC_PERIOD_NS - 1}ns` } }));
    expect(errors(below).some((m) => /below the minimum basic period/.test(m))).toBe(true);
  });

  it("a macro period of exactly MAX_SLOTS basic periods, and one more", () => {
    const two = [
      mod("a", { period_ns: MIN_BASIC_PERIOD_NS }),
      mod("b", { period_ns: MIN_BASIC_PERIOD_NS, priority: 2 }),
    ];
    const most = checkEdits(two, edits({ b: { period: `${MIN_BASIC_PERIOD_NS * MAX_SLOTS}ns` } }));
    expect(most.slots).toBe(MAX_SLOTS);
    expect(errors(most)).toEqual([]);
    const over = checkEdits(two, edits({ b: { period: `${MIN_BASIC_PERIOD_NS * (MAX_SLOTS + 1)}ns` } }));
    expect(over.slots).toBe(MAX_SLOTS + 1);
    expect(errors(over).some((m) => new RegExp(`at most ${MAX_SLOTS}`).test(m))).toBe(true);
  });

  it("utilization: a warning above UTILIZATION_WARNING, an error above UTILIZATION_ERROR", () => {
    const busy = (share: number) => [mod("a", { period_ns: 1_000_000, exec_ns: pct(0, share * 1_000_000) })];
    expect(executorLoads(busy(UTILIZATION_WARNING))[0].level).toBe(null);
    expect(executorLoads(busy(UTILIZATION_WARNING + 0.001))[0].level).toBe("warning");
    expect(executorLoads(busy(UTILIZATION_ERROR))[0].level).toBe("warning");
    expect(executorLoads(busy(UTILIZATION_ERROR + 0.001))[0].level).toBe("error");
  });

  it("one change holds at most MAX_CHANGES modules", () => {
    const many = (n: number) =>
      Array.from({ length: n }, (_, i) => mod(`m${i}`, { operationtype: "sporadic", period_ns: 0, priority: i }));
    const off = (mods: ModuleInfo[]) => new Map(mods.map((m) => [m.name, { enabled: false } as Edit]));
    const most = many(MAX_CHANGES);
    const some = [...most, mod("p")]; // a periodic module keeps a basic period
    expect(checkEdits(some, off(most)).changes.length).toBe(MAX_CHANGES);
    expect(errors(checkEdits(some, off(most))).some((m) => /at most/.test(m))).toBe(false);
    const over = many(MAX_CHANGES + 1);
    expect(
      errors(checkEdits([...over, mod("p")], off(over))).some((m) =>
        new RegExp(`at most ${MAX_CHANGES} in one change`).test(m),
      ),
    ).toBe(true);
  });
});
