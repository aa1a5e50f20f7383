// shots.ts -- a capture's shots as the plot panel shows them: x is the time from the shot's own
// trigger row ((seq − trigger seq) × basic period: 0 is the trigger, exact whatever the decimation),
// one shot or several overlaid on that axis with their series named apart, and how many rows to
// ask for (GET /captures/{id}/shots/{n}?every=) so that a big shot stays a few million values.
import type { components } from "../api/schema";
import type { FixedRows } from "../plot/ring";

type S = components["schemas"];
export type ShotRows = S["ShotRows"];
export type ShotSummary = S["ShotSummary"];

/** Values a shot is fetched with at most (rows × channels): every n-th row beyond. */
export const SHOT_BUDGET = 2_000_000;

/** The `every` to fetch a shot of `rows` rows and `channels` channels with. */
export function everyFor(rows: number, channels: number, budget = SHOT_BUDGET): number {
  return Math.max(1, Math.ceil((rows * Math.max(1, channels)) / budget));
}

/** Row k's time from the trigger row, in ns: (seq − trigger seq) × basic period (integers). */
export function offsetsNs(seq: readonly number[], triggerSeq: number, basicPeriodNs: number): number[] {
  return seq.map((s) => (s - triggerSeq) * basicPeriodNs);
}

/** Row k's time from the trigger row, in seconds: the panel's x axis. */
export function relativeSeconds(seq: readonly number[], triggerSeq: number, basicPeriodNs: number): Float64Array {
  return Float64Array.from(offsetsNs(seq, triggerSeq, basicPeriodNs), (ns) => ns / 1e9);
}

/** A shown shot: its rows and the tag that names its series apart from another shot's. */
export interface Shown {
  rows: ShotRows;
  tag: string;
}

/** The tag of a shot: its capture's name (else its id) and its number, "square#3". */
export function shotTag(capture: { id: string; name: string }, shot: number): string {
  return `${capture.name.trim() || capture.id}#${shot}`;
}

/** The series' names: the channels' paths for one shot; "<tag>: <path>" for several, the tags made
 * distinct ("sq#3", "sq#3 (2)") when the same shot is shown twice. */
export function seriesNames(shots: readonly { tag: string; paths: readonly string[] }[]): string[][] {
  if (shots.length === 1) return [[...shots[0].paths]];
  const seen = new Map<string, number>();
  return shots.map((s) => {
    const n = (seen.get(s.tag) ?? 0) + 1;
    seen.set(s.tag, n);
    const tag = n > 1 ? `${s.tag} (${n})` : s.tag;
    return s.paths.map((p) => `${tag}: ${p}`);
  });
}

const column = (c: readonly (number | null)[]) => Float64Array.from(c, (v) => (v === null ? Number.NaN : v));

/** The rows the plot panel shows for one shot or several overlaid: one x axis of the time from
 * each shot's own trigger (their rows merged where they fall at the same time), the trigger marked
 * at 0.  One shot keeps its seqs (a jump is drawn as a gap: rows it lacks); overlaid shots are
 * sparse (each series drawn from its own rows) and their seq column is the row from the trigger
 * in the first shot's basic period. */
export function plotRows(shots: readonly Shown[]): FixedRows {
  const names = seriesNames(shots.map((s) => ({ tag: s.tag, paths: s.rows.channels.map((c) => c.path) })));
  const marks = [{ x: 0, label: "trigger" }];
  if (shots.length === 1) {
    const r = shots[0].rows;
    return {
      names: names[0],
      seq: r.seq,
      t: relativeSeconds(r.seq, r.summary.trigger_seq, r.basic_period_ns),
      cols: r.columns.map(column),
      decimation: r.every,
      sparse: false,
      marks,
    };
  }
  const offsets = shots.map((s) => offsetsNs(s.rows.seq, s.rows.summary.trigger_seq, s.rows.basic_period_ns));
  // the union of every shot's offsets, ascending (each shot's are ascending already)
  const all = [...new Set(offsets.flat())].sort((a, b) => a - b);
  const at = new Map(all.map((ns, i) => [ns, i]));
  const cols: Float64Array[] = [];
  shots.forEach((s, k) => {
    for (const values of s.rows.columns) {
      const c = new Float64Array(all.length).fill(Number.NaN);
      offsets[k].forEach((ns, i) => {
        const v = values[i];
        if (v !== null && v !== undefined) c[at.get(ns)!] = v;
      });
      cols.push(c);
    }
  });
  const period = shots[0].rows.basic_period_ns;
  return {
    names: names.flat(),
    seq: Float64Array.from(all, (ns) => ns / period),
    t: Float64Array.from(all, (ns) => ns / 1e9),
    cols,
    decimation: 1,
    sparse: true,
    marks,
  };
}

/** The line under the plot for a shot: its trigger row, pre/post counts, drops and cause. */
export function summaryText(s: ShotSummary, every = 1): string {
  const parts = [
    `trigger seq ${s.trigger_seq}`,
    `${s.pre_rows} rows before, ${s.post_rows} after (${s.rows} rows, seq ${s.first_seq}–${s.last_seq})`,
    `${s.drops} dropped`,
    `cause: ${s.cause}`,
  ];
  if (every > 1) parts.push(`1 row in ${every} shown`);
  return parts.join(" · ");
}
