// validate.ts -- checks pending module edits on the client, as irpd will: periods against the
// minimum basic period, the new GCD (basic period) and LCM (macro period), the estimated
// utilization of each executor, duplicate priorities, the priority range and the change-list
// size.  The limits are irpd's, generated from protocol/control.json (src/api/protocol.ts).  The
// dry run's answer stays authoritative; this only says early what is wrong, while typing.
import {
  MAX_CHANGES,
  MAX_SLOTS,
  MIN_BASIC_PERIOD_NS,
  PRIORITY_MAX,
  PRIORITY_MIN,
  UTILIZATION_ERROR,
  UTILIZATION_WARNING,
} from "../api/protocol";
import type { ModuleChange, ModuleInfo } from "./types";
import { formatNs, formatPercent, parsePeriod } from "./units";

/** What the operator typed for one module; absent fields are untouched. */
export interface Edit {
  period?: string;
  priority?: string;
  enabled?: boolean;
}

export type Level = "error" | "warning" | "info";
export type Field = "period" | "priority" | "enabled";

export interface Issue {
  level: Level;
  module?: string;
  field?: Field;
  message: string;
}

export interface ExecutorLoad {
  executor: string;
  /** Σ max(exec p99, budget) / period over the executor's enabled periodic modules */
  fraction: number;
  level: Level | null;
}

export interface Check {
  /** the fields that differ from what runs, parsed; empty when nothing changes */
  changes: ModuleChange[];
  issues: Issue[];
  /** every edited field parses (the changes can be sent for a dry run) */
  complete: boolean;
  basicNs: number | null;
  macroNs: number | null;
  slots: number | null;
  load: ExecutorLoad[];
}

export interface Limits {
  /** irpd refuses a basic period below this (status.min_basic_period_ns; irpd's default MIN_BASIC_PERIOD_NS) */
  minBasicNs: number;
  /** irpd refuses a macro period of more basic periods than this */
  maxSlots: number;
  utilizationError: number;
  utilizationWarning: number;
}

export const DEFAULT_LIMITS: Limits = {
  minBasicNs: MIN_BASIC_PERIOD_NS,
  maxSlots: MAX_SLOTS,
  utilizationError: UTILIZATION_ERROR,
  utilizationWarning: UTILIZATION_WARNING,
};

export function gcd(a: number, b: number): number {
  a = Math.abs(a);
  b = Math.abs(b);
  while (b) [a, b] = [b, a % b];
  return a;
}

/** The least common multiple, or Infinity past 2^53 (no exact macro period). */
export function lcm(a: number, b: number): number {
  if (!a || !b) return 0;
  const l = (a / gcd(a, b)) * b;
  return Number.isSafeInteger(l) ? l : Infinity;
}

export function parsePriority(text: string): { ok: true; value: number } | { ok: false; error: string } {
  const t = text.trim();
  if (!/^-?\d+$/.test(t))
    return {
      ok: false,
      error: `priority "${t}" must be a whole number from ${PRIORITY_MIN} to ${PRIORITY_MAX} (lowest = first)`,
    };
  const value = Number(t);
  if (value < PRIORITY_MIN) return { ok: false, error: `priority ${t} is below ${PRIORITY_MIN}` };
  if (value > PRIORITY_MAX) return { ok: false, error: `priority ${t} is above ${PRIORITY_MAX}` };
  return { ok: true, value };
}

/** Executor loads: Σ max(exec p99, budget) / period of the enabled periodic modules. */
export function executorLoads(
  modules: {
    executor: string;
    operationtype: string;
    period_ns: number;
    enabled: boolean;
    budget_ns?: number;
    exec_ns?: { p99: number };
  }[],
  limits: Pick<Limits, "utilizationError" | "utilizationWarning"> = DEFAULT_LIMITS,
): ExecutorLoad[] {
  const sums = new Map<string, number>();
  for (const m of modules) {
    if (!sums.has(m.executor)) sums.set(m.executor, 0);
    if (m.operationtype !== "periodic" || !m.enabled || !(m.period_ns > 0)) continue;
    const exec = Math.max(m.budget_ns ?? 0, m.exec_ns?.p99 ?? 0);
    sums.set(m.executor, sums.get(m.executor)! + exec / m.period_ns);
  }
  return [...sums].map(([executor, fraction]) => ({
    executor,
    fraction,
    level: fraction > limits.utilizationError ? "error" : fraction > limits.utilizationWarning ? "warning" : null,
  }));
}

/** Checks `edits` against the running `modules`. */
export function checkEdits(modules: ModuleInfo[], edits: Map<string, Edit>, limits: Limits = DEFAULT_LIMITS): Check {
  const issues: Issue[] = [];
  const changes: ModuleChange[] = [];
  let complete = true;
  const after = modules.map((m) => ({ ...m }));

  for (const [name, e] of edits) {
    const m = after.find((x) => x.name === name);
    if (!m) {
      issues.push({ level: "error", module: name, message: `${name} is no longer in the running set` });
      complete = false;
      continue;
    }
    const change: ModuleChange = { name };
    if (e.period !== undefined) {
      const p = parsePeriod(e.period);
      if (!p.ok) {
        issues.push({ level: "error", module: name, field: "period", message: `${name}: ${p.error}` });
        complete = false;
      } else if (m.operationtype !== "periodic") {
        issues.push({
          level: "error",
          module: name,
          field: "period",
          message: `${name} is ${m.operationtype}: only periodic modules have a period`,
        });
        complete = false;
      } else if (p.ns !== m.period_ns) {
        if (p.ns < limits.minBasicNs)
          issues.push({
            level: "error",
            module: name,
            field: "period",
            message: `${name}: period ${formatNs(p.ns)} is below the minimum basic period ${formatNs(limits.minBasicNs)}`,
          });
        const execP99 = m.exec_ns?.p99 ?? 0;
        if (m.enabled && execP99 > p.ns)
          issues.push({
            level: "error",
            module: name,
            field: "period",
            message: `${name}: period ${formatNs(p.ns)} is shorter than its measured execution time (p99 ${formatNs(execP99)})`,
          });
        m.period_ns = p.ns;
        change.period_ns = p.ns;
      }
    }
    if (e.priority !== undefined) {
      const p = parsePriority(e.priority);
      if (!p.ok) {
        issues.push({ level: "error", module: name, field: "priority", message: `${name}: ${p.error}` });
        complete = false;
      } else if (p.value !== m.priority) {
        m.priority = p.value;
        change.priority = p.value;
      }
    }
    if (e.enabled !== undefined && e.enabled !== m.enabled) {
      m.enabled = e.enabled;
      change.enabled = e.enabled;
    }
    if (Object.keys(change).length > 1) changes.push(change);
  }

  // basic and macro period of the periodic modules (irpd counts disabled ones too: they keep their slots)
  const periods = after.filter((m) => m.operationtype === "periodic" && m.period_ns > 0).map((m) => m.period_ns);
  let basicNs: number | null = null;
  let macroNs: number | null = null;
  let slots: number | null = null;
  if (periods.length) {
    basicNs = periods.reduce(gcd);
    macroNs = periods.reduce(lcm);
    slots = Number.isFinite(macroNs) ? macroNs / basicNs : Infinity;
    const before = modules.filter((m) => m.operationtype === "periodic" && m.period_ns > 0).map((m) => m.period_ns);
    const oldBasic = before.length ? before.reduce(gcd) : null;
    const oldMacro = before.length ? before.reduce(lcm) : null;
    if (basicNs < limits.minBasicNs)
      issues.push({
        level: "error",
        message: `the new basic period (GCD of the periods) would be ${formatNs(basicNs)}, below the minimum ${formatNs(limits.minBasicNs)}: make the periods multiples of at least ${formatNs(limits.minBasicNs)}`,
      });
    else if (oldBasic !== null && basicNs !== oldBasic)
      issues.push({ level: "info", message: `basic period ${formatNs(oldBasic)} → ${formatNs(basicNs)}` });
    if (slots > limits.maxSlots)
      issues.push({
        level: "error",
        message: `the macro period (LCM of the periods) would span ${Number.isFinite(slots) ? slots : "too many"} basic periods; at most ${limits.maxSlots}: choose periods that are multiples of each other`,
      });
    else if (oldMacro !== null && macroNs !== oldMacro)
      issues.push({
        level: "info",
        message: `macro period ${formatNs(oldMacro)} → ${formatNs(macroNs)} (${slots} slots)`,
      });
  } else {
    issues.push({
      level: "error",
      message: "no periodic module left: there would be no basic period to run the set on",
    });
  }

  const load = executorLoads(after, limits);
  for (const l of load) {
    if (l.level === "error")
      issues.push({
        level: "error",
        message: `executor ${l.executor}: estimated utilization ${formatPercent(l.fraction)} is over ${formatPercent(limits.utilizationError, 0)}`,
      });
    else if (l.level === "warning")
      issues.push({
        level: "warning",
        message: `executor ${l.executor}: estimated utilization ${formatPercent(l.fraction)} is over ${formatPercent(limits.utilizationWarning, 0)}`,
      });
  }
  if (changes.length > MAX_CHANGES)
    issues.push({
      level: "error",
      message: `${changes.length} modules changed at once; irpd takes at most ${MAX_CHANGES} in one change`,
    });

  for (const w of duplicatePriorities(after)) issues.push(w);
  return { changes, issues, complete, basicNs, macroNs, slots, load };
}

/** Modules of one executor and operation type (periodic or sporadic) sharing a priority: they run in file order. */
export function duplicatePriorities(
  modules: { name: string; executor: string; operationtype: string; priority: number }[],
): Issue[] {
  const groups = new Map<string, string[]>();
  for (const m of modules) {
    if (m.operationtype !== "periodic" && m.operationtype !== "sporadic") continue;
    const key = `${m.executor}\u0000${m.operationtype}\u0000${m.priority}`;
    groups.set(key, [...(groups.get(key) ?? []), m.name]);
  }
  const out: Issue[] = [];
  for (const [key, names] of groups) {
    if (names.length < 2) continue;
    const [executor, op, priority] = key.split("\u0000");
    for (const name of names)
      out.push({
        level: "warning",
        module: name,
        field: "priority",
        message: `${names.join(", ")} (${op}, executor ${executor}) share priority ${priority}: they run in file order`,
      });
  }
  return out;
}

/** The issues with one line per distinct message (a group warning marks every module it names). */
export function distinctMessages(issues: Issue[]): Issue[] {
  const seen = new Set<string>();
  return issues.filter((i) => !seen.has(i.message) && (seen.add(i.message), true));
}
