// activation.ts -- what activating a stored set will do, from irpd's check of it against what runs
// now (POST /sets/{id}/check): the shared variables it adds, removes, moves and converts, the modules the
// layout makes irpd load anew, whether it goes in by a hot swap or only by a restart of irpd, and
// the activation request that follows (a restart only once the operator confirmed it).
import type { SwapReport, Validation, VariableChanges } from "./types";
import { formatNs } from "./units";

export type VariableRow =
  | { kind: "added"; path: string }
  | { kind: "removed"; path: string }
  | {
      kind: "moved";
      path: string;
      from: number;
      to: number;
      reason: string | null;
      fromType: string | null;
      toType: string | null;
    }
  | { kind: "converted"; path: string; fromType: string; toType: string; dropped: string[] };

/** The variable diff as the page lists it. */
export interface VariableDiff {
  /** nothing added, removed, moved, converted or replaced (or the set declares no shared variables) */
  unchanged: boolean;
  rows: VariableRow[];
  /** running modules built against the old layout: loaded anew, not kept */
  replaced: string[];
  /** the new layout's hash (null: no layout) */
  layout: string | null;
  /** one line: "2 added, 1 removed, 1 moved, 1 converted; 1 module replaced" or "shared variables unchanged" */
  summary: string;
}

const plural = (n: number, one: string, many = `${one}s`) => `${n} ${n === 1 ? one : many}`;

export function variableDiff(v: VariableChanges | null | undefined): VariableDiff {
  const added = v?.added ?? [];
  const removed = v?.removed ?? [];
  const moved = v?.moved ?? [];
  const converted = v?.converted ?? [];
  const replaced = v?.replaced ?? [];
  const rows: VariableRow[] = [
    ...added.map((path) => ({ kind: "added" as const, path })),
    ...removed.map((path) => ({ kind: "removed" as const, path })),
    ...moved.map((m) => ({
      kind: "moved" as const,
      path: m.path,
      from: m.from,
      to: m.to,
      reason: m.reason ?? null,
      fromType: m.from_type ?? null,
      toType: m.to_type ?? null,
    })),
    ...converted.map((c) => ({
      kind: "converted" as const,
      path: c.path,
      fromType: c.from_type,
      toType: c.to_type,
      dropped: c.dropped,
    })),
  ];
  const unchanged = rows.length === 0 && replaced.length === 0;
  const parts = [
    added.length ? `${added.length} added` : "",
    removed.length ? `${removed.length} removed` : "",
    moved.length ? `${moved.length} moved` : "",
    converted.length ? `${converted.length} converted` : "",
  ].filter(Boolean);
  const summary = unchanged
    ? "shared variables unchanged"
    : `shared variables: ${parts.length ? parts.join(", ") : "none added, removed, moved or converted"}` +
      (replaced.length ? `; ${plural(replaced.length, "module")} replaced because of the layout` : "");
  return { unchanged, rows, replaced, layout: v?.layout ?? null, summary };
}

export type ActivationMode = "online" | "restart";

/** How the set can be activated, from its (fresh) validation. */
export type ActivationPlan =
  | { kind: "online"; variables: VariableDiff }
  | { kind: "restart"; reason: string; expectedDowntimeNs: number | null; downtime: string }
  | { kind: "invalid"; errors: string[] }
  | { kind: "unchecked"; why: string };

export function activationPlan(v: Validation): ActivationPlan {
  if (v.valid === false) return { kind: "invalid", errors: v.errors };
  if (v.valid !== true) return { kind: "unchecked", why: v.warnings.join("; ") || "irpd did not check the set" };
  if (v.online === false) {
    const ns = v.restart?.expected_downtime_ns ?? null;
    return {
      kind: "restart",
      reason: v.restart?.reason ?? "irpd cannot take this set by a hot swap (it gave no reason)",
      expectedDowntimeNs: ns,
      downtime: ns === null ? "unknown" : formatNs(ns),
    };
  }
  // online true, or null from an agent that predates online change: a hot swap, as before
  return { kind: "online", variables: variableDiff(v.variables) };
}

/**
 * The body of POST /sets/{id}/activate for a plan, or why it may not be sent yet: a set that
 * needs a restart goes only with the operator's explicit confirmation; an invalid or unchecked
 * one not at all.
 */
export function activationRequest(
  plan: ActivationPlan,
  restartConfirmed: boolean,
): { mode: ActivationMode } | { refused: string } {
  switch (plan.kind) {
    case "online":
      return { mode: "online" };
    case "restart":
      return restartConfirmed ? { mode: "restart" } : { refused: "confirm the restart of irpd first" };
    case "invalid":
      return { refused: "irpd refuses this set: fix the errors and upload it again" };
    case "unchecked":
      return { refused: `the set is not checked against what runs now (${plan.why}); check again` };
  }
}

/** A key that changes when what activation would do changes (the plan shown vs. a fresh check). */
export function planKey(v: Validation): string {
  return JSON.stringify([
    v.valid,
    v.online ?? null,
    v.restart ?? null,
    v.variables ?? null,
    v.modules ?? null,
    v.schedule ?? null,
    v.errors,
  ]);
}

/** How a swap report's set went in, and the measured downtime of a restart (null: none or not measured). */
export function reportMode(r: SwapReport): { mode: ActivationMode | null; downtimeNs: number | null } {
  const mode = r.mode === "online" || r.mode === "restart" ? r.mode : null;
  const downtimeNs = typeof r.downtime_ns === "number" && Number.isFinite(r.downtime_ns) ? r.downtime_ns : null;
  return { mode, downtimeNs };
}
