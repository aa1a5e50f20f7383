// activation.test.ts -- activating a stored set: the variable diff as listed, the plan from irpd's
// check (hot swap, restart, invalid, unchecked), the confirm gating of a restart and the mode
// sent, the review that checks again right before activating, the modules it keeps, replaces,
// starts and stops, and the swap report's variables, replaced modules and downtime.
import { describe, expect, it } from "vitest";
import type { AppContext } from "../../src/app/context";
import { activationPlan, activationRequest, planKey, reportMode, variableDiff } from "../../src/ops/activation";
import { ActivationReview } from "../../src/ops/activation-review";
import { renderSwapReport } from "../../src/ops/swap-report-view";
import type { Schedule, SwapReport, Validation, VariableChanges } from "../../src/ops/types";

const sched = (macro: number): Schedule => ({
  basic_period_ns: 1_000_000,
  macro_period_ns: macro,
  slots: Array.from({ length: macro / 1_000_000 }, (_, i) => ({
    index: i,
    offset_ns: i * 1_000_000,
    modules: i === 0 ? ["counter", "adder"] : ["counter"],
  })),
  modules: [
    {
      name: "counter",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: 1_000_000,
      deadline_ns: 0,
      priority: 1,
      executor: "main",
    },
    {
      name: "adder",
      moduletype: "thread",
      operationtype: "periodic",
      period_ns: macro,
      deadline_ns: 0,
      priority: 2,
      executor: "main",
    },
  ],
});

const CHANGES: VariableChanges = {
  layout: "0123456789abcdef0123",
  added: ["oc.extra"],
  removed: ["oc.gone"],
  moved: [
    {
      path: "oc.retyped",
      from: 16,
      to: 64,
      from_type: "int32_t",
      to_type: "int16_t",
      reason: "oc.retyped: int32_t to int16_t may lose values",
    },
  ],
  converted: [{ path: "oc.wide", from_type: "int16_t", to_type: "int32_t", dropped: [] }],
  replaced: ["adder"],
};
const UNCHANGED: VariableChanges = {
  layout: "0123456789abcdef0123",
  added: [],
  removed: [],
  moved: [],
  converted: [],
  replaced: [],
};

const validation = (over: Partial<Validation> = {}): Validation => ({
  valid: true,
  errors: [],
  problems: [],
  warnings: [],
  schedule: sched(2_000_000) as unknown as Validation["schedule"],
  online: true,
  restart: null,
  variables: UNCHANGED,
  ...over,
});
const RESTART = validation({
  online: false,
  variables: null,
  restart: {
    reason: "the set's shared-variable layout cannot replace the running one online: oc.a moved",
    expected_downtime_ns: 250_000_000,
  },
});

describe("variableDiff", () => {
  it("lists added, removed, moved and converted variables and the modules replaced", () => {
    const d = variableDiff(CHANGES);
    expect(d.unchanged).toBe(false);
    expect(d.rows).toEqual([
      { kind: "added", path: "oc.extra" },
      { kind: "removed", path: "oc.gone" },
      {
        kind: "moved",
        path: "oc.retyped",
        from: 16,
        to: 64,
        reason: "oc.retyped: int32_t to int16_t may lose values",
        fromType: "int32_t",
        toType: "int16_t",
      },
      { kind: "converted", path: "oc.wide", fromType: "int16_t", toType: "int32_t", dropped: [] },
    ]);
    expect(d.replaced).toEqual(["adder"]);
    expect(d.summary).toBe(
      "shared variables: 1 added, 1 removed, 1 moved, 1 converted; 1 module replaced because of the layout",
    );
  });

  it("says so when nothing changes, or the set has no shared variables", () => {
    expect(variableDiff(UNCHANGED)).toMatchObject({ unchanged: true, rows: [], summary: "shared variables unchanged" });
    expect(variableDiff(null)).toMatchObject({ unchanged: true, layout: null, summary: "shared variables unchanged" });
  });

  it("counts modules replaced alone", () => {
    expect(variableDiff({ ...UNCHANGED, replaced: ["a", "b"] }).summary).toBe(
      "shared variables: none added, removed, moved or converted; 2 modules replaced because of the layout",
    );
  });
});

describe("activationPlan and activationRequest", () => {
  it("an online set goes by a hot swap, mode online, no confirmation needed", () => {
    const plan = activationPlan(validation({ variables: CHANGES }));
    expect(plan.kind).toBe("online");
    expect(activationRequest(plan, false)).toEqual({ mode: "online" });
  });

  it("a set that needs a restart is not sent without the confirmation, then with mode restart", () => {
    const plan = activationPlan(RESTART);
    expect(plan).toMatchObject({ kind: "restart", expectedDowntimeNs: 250_000_000, downtime: "250 ms" });
    expect(activationRequest(plan, false)).toEqual({ refused: "confirm the restart of irpd first" });
    expect(activationRequest(plan, true)).toEqual({ mode: "restart" });
  });

  it("an unknown expected downtime reads 'unknown'", () => {
    const plan = activationPlan(
      validation({ online: false, restart: { reason: "executors differ", expected_downtime_ns: null } }),
    );
    expect(plan).toMatchObject({ kind: "restart", expectedDowntimeNs: null, downtime: "unknown" });
  });

  it("an invalid or unchecked set is never sent, confirmed or not", () => {
    const invalid = activationPlan(validation({ valid: false, online: false, errors: ["module.xml:3: bad"] }));
    expect(invalid.kind).toBe("invalid");
    expect("refused" in activationRequest(invalid, true)).toBe(true);
    const unchecked = activationPlan(
      validation({ valid: null, warnings: ["not checked: irpd unreachable"], online: null }),
    );
    expect(unchecked).toEqual({ kind: "unchecked", why: "not checked: irpd unreachable" });
    expect("refused" in activationRequest(unchecked, true)).toBe(true);
  });

  it("an agent without online change (online null) means a hot swap", () => {
    expect(activationPlan(validation({ online: null, variables: null })).kind).toBe("online");
  });

  it("the plan key changes with what activation would do", () => {
    expect(planKey(validation())).toBe(planKey(validation()));
    expect(planKey(validation())).not.toBe(planKey(validation({ variables: CHANGES })));
    expect(planKey(validation())).not.toBe(planKey(RESTART));
    const fates = { kept: ["counter"], started: [], stopped: [], replaced: [] };
    expect(planKey(validation({ modules: fates }))).not.toBe(
      planKey(
        validation({
          modules: { ...fates, kept: [], started: ["counter"], stopped: ["counter"], replaced: ["counter"] },
        }),
      ),
    );
  });
});

describe("reportMode", () => {
  it("reads mode and downtime when the report has them", () => {
    expect(reportMode({ kept: [], started: [], stopped: [], replaced: [], mode: "online" })).toEqual({
      mode: "online",
      downtimeNs: null,
    });
    expect(
      reportMode({ kept: [], started: [], stopped: [], replaced: [], mode: "restart", downtime_ns: 180_000_000 }),
    ).toEqual({
      mode: "restart",
      downtimeNs: 180_000_000,
    });
  });
});

describe("renderSwapReport", () => {
  const q = (root: Element, id: string) => root.querySelector(`[data-testid=${id}]`);
  it("shows the variables the swap changed", () => {
    const r: SwapReport = {
      kept: ["counter"],
      started: ["adder"],
      stopped: [],
      replaced: [],
      missed_periods: 0,
      variables: CHANGES,
      mode: "online",
      downtime_ns: null,
    };
    const e = renderSwapReport("done", r);
    expect(q(e, "report-mode")?.textContent).toBe("hot swap");
    expect(q(e, "report-downtime")).toBeNull();
    expect(q(e, "report-variables-summary")?.textContent).toMatch(/1 added, 1 removed, 1 moved/);
    expect(e.querySelector("[data-variable='oc.retyped']")?.textContent).toContain(
      "int32_t → int16_t: not convertible without loss (oc.retyped: int32_t to int16_t may lose values)",
    );
    expect(e.querySelector("[data-variable='oc.wide']")?.textContent).toContain("≈ convertedoc.wideint16_t → int32_t");
    expect(q(e, "report-variables-replaced")?.textContent).toContain("adder");
    expect(q(e, "report-replaced")?.textContent).toBe("—");
  });

  it("names the modules replaced (started anew under their name)", () => {
    const e = renderSwapReport("done", {
      kept: [],
      started: ["adder"],
      stopped: ["adder"],
      replaced: ["adder"],
      mode: "online",
    });
    expect(q(e, "report-replaced")?.textContent).toBe("adder");
  });

  it("shows a restart's measured downtime", () => {
    const e = renderSwapReport("done", {
      kept: [],
      started: ["counter"],
      stopped: ["counter"],
      replaced: [],
      mode: "restart",
      downtime_ns: 180_000_000,
      variables: null,
    });
    expect(q(e, "report-mode")?.textContent).toBe("restart of irpd");
    expect(q(e, "report-downtime")?.textContent).toBe("180 ms");
    expect(q(e, "report-variables-summary")?.textContent).toMatch(/started at zero/);
  });

  it("a report without variables says they are unchanged", () => {
    const e = renderSwapReport("done", { kept: ["a"], started: [], stopped: [], replaced: [], mode: "online" });
    expect(q(e, "report-variables-summary")?.textContent).toBe("shared variables unchanged");
  });
});

// ActivationReview against a fake API: check answers `checks` in turn, schedule answers the running table.
function setup(checks: Validation[]) {
  const calls: { path: string; body?: unknown }[] = [];
  const reports: string[] = [];
  let n = 0;
  const answer = (data: unknown, status = 200) => ({
    data: status < 300 ? data : undefined,
    error: status < 300 ? undefined : data,
    response: new Response(null, { status }),
  });
  const ctx = {
    api: {
      GET: async (path: string) => {
        calls.push({ path });
        return answer(sched(1_000_000));
      },
      POST: async (path: string, opts: { body?: unknown }) => {
        calls.push({ path, body: opts.body });
        if (path.endsWith("/check"))
          return answer({
            id: "abc",
            created: "",
            by: null,
            files: [],
            active: false,
            validation: checks[Math.min(n++, checks.length - 1)],
          });
        return answer({ kept: ["counter"], started: [], stopped: [], missed_periods: 0, variables: CHANGES });
      },
    },
    session: { name: "op", role: "operator", csrf: "c" },
    can: () => true,
    notify: () => {},
  } as unknown as AppContext;
  const review = new ActivationReview(ctx, "abc", (title) => reports.push(title));
  document.body.replaceChildren(review.element);
  const q = <T extends Element = HTMLElement>(id: string) => document.querySelector<T>(`[data-testid=${id}]`);
  const activations = () => calls.filter((c) => c.path.endsWith("/activate"));
  return { calls, reports, q, activations };
}

const flush = async () => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
  await new Promise((r) => setTimeout(r, 0));
};

describe("ActivationReview", () => {
  it("checks first, shows the slot tables beside the variable diff, and activates online", async () => {
    const s = setup([validation({ variables: CHANGES })]);
    await flush();
    expect(s.calls.map((c) => c.path)).toEqual(["/api/v1/sets/{set_id}/check", "/api/v1/schedule"]);
    expect(s.q("plan-before")).not.toBeNull();
    expect(s.q("plan-after")?.querySelectorAll("tr.changed").length).toBe(1); // the second slot is new
    expect(s.q("plan-variables-summary")?.textContent).toMatch(/1 added/);
    expect(s.q("plan-variables-replaced")?.textContent).toContain("adder");
    expect(s.q("plan-restart")).toBeNull();
    expect(s.q("plan-restart-confirm")).toBeNull();
    const go = s.q<HTMLButtonElement>("plan-activate")!;
    expect(go.disabled).toBe(false);
    go.click();
    await flush();
    // checked once more right before, then sent with mode online
    expect(s.calls.filter((c) => c.path.endsWith("/check")).length).toBe(2);
    expect(s.activations()).toEqual([{ path: "/api/v1/sets/{set_id}/activate", body: { mode: "online" } }]);
    expect(s.reports).toEqual(["Set abc activated"]);
  });

  it("shows the modules the swap keeps, replaces, starts and stops, each once", async () => {
    const s = setup([
      validation({
        modules: { kept: ["counter"], started: ["adder", "fresh"], stopped: ["adder", "old"], replaced: ["adder"] },
      }),
    ]);
    await flush();
    expect(s.q("plan-modules-kept")?.textContent).toBe("counter");
    expect(s.q("plan-modules-replaced")?.textContent).toBe("adder");
    expect(s.q("plan-modules-new")?.textContent).toBe("fresh");
    expect(s.q("plan-modules-removed")?.textContent).toBe("old");
    expect(s.q("plan-modules")?.textContent).toMatch(/replaced: stopped, started anew/);
  });

  it("an invalid set (a module built against another layout) lists no modules and cannot be activated", async () => {
    const s = setup([
      validation({
        valid: false,
        online: false,
        modules: null,
        errors: ["module 'adder': adder.so: … rebuild it against the set's .glb files"],
        problems: [{ message: "module 'adder': adder.so: … rebuild it against the set's .glb files", module: "adder" }],
      }),
    ]);
    await flush();
    expect(s.q("plan-modules")).toBeNull();
    expect(document.body.textContent).toContain("rebuild it against the set's .glb files");
    expect(s.q<HTMLButtonElement>("plan-activate")!.disabled).toBe(true);
  });

  it("an unchanged layout says so", async () => {
    const s = setup([validation()]);
    await flush();
    expect(s.q("plan-variables-summary")?.textContent).toBe("shared variables unchanged");
  });

  it("a set that needs a restart shows why and the downtime, and activates only once confirmed, with mode restart", async () => {
    const s = setup([RESTART]);
    await flush();
    expect(s.q("plan-restart-reason")?.textContent).toMatch(/cannot replace the running one online/);
    expect(s.q("plan-downtime")?.textContent).toBe("250 ms");
    expect(s.q("plan-restart")?.textContent).toMatch(/shared variables start afresh/);
    const go = s.q<HTMLButtonElement>("plan-activate")!;
    expect(go.textContent).toBe("Restart irpd onto this set");
    expect(go.disabled).toBe(true);
    go.click(); // a disabled button sends nothing, and neither would the handler
    await flush();
    expect(s.activations()).toEqual([]);
    const box = s.q<HTMLInputElement>("plan-restart-confirm")!;
    box.checked = true;
    box.dispatchEvent(new Event("change"));
    expect(go.disabled).toBe(false);
    go.click();
    await flush();
    expect(s.activations()).toEqual([{ path: "/api/v1/sets/{set_id}/activate", body: { mode: "restart" } }]);
  });

  it("when what runs changed since the plan was shown, it shows the new plan and sends nothing", async () => {
    const s = setup([validation(), RESTART]);
    await flush();
    s.q<HTMLButtonElement>("plan-activate")!.click();
    await flush();
    expect(s.activations()).toEqual([]);
    expect(s.q("plan-status")?.textContent).toMatch(/review it again/);
    expect(s.q("plan-restart")).not.toBeNull();
    expect(s.q<HTMLButtonElement>("plan-activate")!.disabled).toBe(true);
  });
});
