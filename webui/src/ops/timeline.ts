// timeline.ts -- the slot table (the paper's Table 3) and the timing of one macro period (its
// Figure 2) as plain data, in nanoseconds: what the schedule page and the change preview draw.
//
// Per executor and slot: the periodic modules of the slot in run order, each as long as its
// measured execution time (p50 solid, up to p99 light, a whisker to the max), stacked by p99;
// then the event handler's part: the sporadic modules (run when their event fires); then the
// time left over, where non-real modules run.
import type { ModuleInfo, Schedule, ScheduleModule } from "./types";

export interface SlotCell {
  name: string;
  executor: string;
  priority: number;
  moduletype: string;
  period_ns: number;
}

export interface SlotRow {
  index: number;
  offsetNs: number;
  cells: SlotCell[];
}

export interface SlotTable {
  basicNs: number;
  macroNs: number;
  /** slots in the macro period (may be more than rows) */
  slots: number;
  rows: SlotRow[];
  /** the widest row's cell count: the table's module columns */
  columns: number;
  /** sporadic and non-real modules: outside the table */
  outside: ScheduleModule[];
}

/** Table 3 from GET /schedule; at most `maxRows` rows. */
export function buildSlotTable(schedule: Schedule, maxRows = 512): SlotTable {
  const byName = new Map(schedule.modules.map((m) => [m.name, m]));
  const rows = schedule.slots.slice(0, maxRows).map((s) => ({
    index: s.index,
    offsetNs: s.offset_ns,
    cells: s.modules.map((name) => {
      const m = byName.get(name);
      return {
        name,
        executor: m?.executor ?? "main",
        priority: m?.priority ?? 0,
        moduletype: m?.moduletype ?? "",
        period_ns: m?.period_ns ?? 0,
      };
    }),
  }));
  return {
    basicNs: schedule.basic_period_ns,
    macroNs: schedule.macro_period_ns,
    slots: schedule.slots.length,
    rows,
    columns: rows.reduce((n, r) => Math.max(n, r.cells.length), 0),
    outside: schedule.modules.filter((m) => m.operationtype !== "periodic"),
  };
}

/** Slot indices whose module lists differ between two tables (new and removed slots count). */
export function changedSlots(before: SlotTable, after: SlotTable): Set<number> {
  const out = new Set<number>();
  const n = Math.max(before.rows.length, after.rows.length);
  for (let i = 0; i < n; i++) {
    const a = before.rows[i];
    const b = after.rows[i];
    if (
      !a ||
      !b ||
      a.offsetNs !== b.offsetNs ||
      a.cells.map((c) => c.name).join() !== b.cells.map((c) => c.name).join()
    )
      out.add(i);
  }
  return out;
}

export type BoxKind = "periodic" | "sporadic";

export interface Box {
  module: string;
  kind: BoxKind;
  slot: number;
  /** ns from the start of the macro period */
  start: number;
  p50: number;
  p99: number;
  max: number;
  /** no run measured yet: drawn as a marker, takes no time */
  measured: boolean;
  /** runs past the end of its slot */
  overflow: boolean;
}

export interface Idle {
  slot: number;
  start: number;
  end: number;
}

export interface Lane {
  executor: string;
  boxes: Box[];
  /** per slot, the time left after the periodic and sporadic parts (non-real work runs there) */
  idle: Idle[];
  /** non-real modules of this executor */
  nonReal: string[];
  /** the largest busy end in a slot, relative to the slot's start */
  busiestNs: number;
}

export interface Timeline {
  basicNs: number;
  macroNs: number;
  slots: number;
  lanes: Lane[];
}

type Figures = Pick<ModuleInfo, "name" | "runs" | "exec_ns" | "enabled" | "state"> &
  Partial<Pick<ModuleInfo, "executor" | "operationtype" | "priority">>;

/** Lays out one macro period from the slot table and the modules' measured execution times. */
export function buildTimeline(schedule: Schedule, figures: Figures[], maxSlots = 4096): Timeline {
  const fig = new Map(figures.map((f) => [f.name, f]));
  const executors: string[] = [];
  for (const m of schedule.modules) if (!executors.includes(m.executor)) executors.push(m.executor);
  executors.sort((a, b) => (a === "main" ? -1 : b === "main" ? 1 : 0));
  const basic = schedule.basic_period_ns;
  const slots = schedule.slots.slice(0, maxSlots);

  const running = (name: string) => {
    const f = fig.get(name);
    return !f || (f.enabled !== false && f.state !== "disabled" && f.state !== "stopped");
  };
  const box = (name: string, kind: BoxKind, slot: number, start: number, slotEnd: number): Box => {
    const f = fig.get(name);
    const e = f?.exec_ns;
    const measured = !!f && f.runs > 0 && !!e && e.count > 0;
    const p50 = measured && running(name) ? Math.max(0, e!.p50) : 0;
    const p99 = measured && running(name) ? Math.max(p50, e!.p99) : 0;
    const max = measured && running(name) ? Math.max(p99, e!.max) : 0;
    return {
      module: name,
      kind,
      slot,
      start,
      p50,
      p99,
      max,
      measured: measured && running(name),
      overflow: start + p99 > slotEnd,
    };
  };

  const lanes: Lane[] = executors.map((executor) => {
    const mods = schedule.modules.filter((m) => m.executor === executor);
    const sporadic = mods
      .filter((m) => m.operationtype === "sporadic")
      .map((m, i) => ({ m, i }))
      .sort((a, b) => a.m.priority - b.m.priority || a.i - b.i)
      .map((x) => x.m.name);
    const nonReal = mods.filter((m) => m.operationtype === "non-real").map((m) => m.name);
    const lane: Lane = { executor, boxes: [], idle: [], nonReal, busiestNs: 0 };
    const mine = new Set(mods.map((m) => m.name));
    for (const s of slots) {
      const slotEnd = s.offset_ns + basic;
      let t = s.offset_ns;
      for (const name of s.modules) {
        if (!mine.has(name)) continue;
        const b = box(name, "periodic", s.index, t, slotEnd);
        lane.boxes.push(b);
        t += b.p99;
      }
      for (const name of sporadic) {
        const b = box(name, "sporadic", s.index, t, slotEnd);
        lane.boxes.push(b);
        t += b.p99;
      }
      lane.busiestNs = Math.max(lane.busiestNs, t - s.offset_ns);
      if (t < slotEnd) lane.idle.push({ slot: s.index, start: t, end: slotEnd });
    }
    return lane;
  });
  return { basicNs: basic, macroNs: schedule.macro_period_ns, slots: slots.length, lanes };
}

/** The time range a view shows: the whole macro period, one slot, or the busy part of one slot. */
export function viewRange(tl: Timeline, slot: number | null, busyOnly: boolean): [number, number] {
  if (slot === null) {
    const end = tl.slots * tl.basicNs || tl.macroNs;
    if (!busyOnly || tl.slots !== 1) return [0, end];
    slot = 0;
  }
  const from = slot * tl.basicNs;
  if (!busyOnly) return [from, from + tl.basicNs];
  const busiest = Math.max(0, ...tl.lanes.map((l) => l.busiestNs));
  // the busy part with a margin, never wider than the slot, never narrower than 1 µs
  const span = Math.min(tl.basicNs, Math.max(1_000, busiest * 1.25));
  return [from, from + span];
}

/** Round tick positions (1, 2, 5 × 10^k ns) covering [from, to], about `count` of them. */
export function ticks(from: number, to: number, count = 8): number[] {
  const range = to - from;
  if (!(range > 0) || count < 1) return [from];
  const raw = range / count;
  const pow = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((k) => k * pow).find((s) => s >= raw)!;
  const out: number[] = [];
  for (let t = Math.ceil(from / step) * step; t <= to + step * 1e-9; t += step) out.push(Math.round(t));
  return out;
}
