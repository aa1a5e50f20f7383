// alarms.ts -- the alarms as the UI holds them (docs/alarms.md): the view kept from the agent's
// push (WebSocket /api/v1/alarms/live: a snapshot, then every change), the banner's words and
// color, the order of the list, and the history's filters as query parameters.
import type { AlarmCounts, AlarmList, AlarmPublic, AlarmTransition } from "./types";

export type AlarmState = AlarmPublic["state"];
export type Severity = AlarmPublic["severity"];

/** One message of the push: a snapshot (first, and after the client fell behind), or a change. */
export interface AlarmPush {
  snapshot?: AlarmList;
  missed?: number;
  transitions?: AlarmTransition[];
  /** the alarms the change touched, as they are now ({key, state: "normal"}: gone from the list) */
  changed?: (AlarmPublic | { key: string; state: "normal" })[];
  counts?: AlarmCounts;
}

export interface AlarmView {
  alarms: Map<string, AlarmPublic>;
  counts: AlarmCounts;
  newest: AlarmPublic | null;
  segment: AlarmList["segment"] | null;
  /** the latest transitions pushed, newest first (at most RECENT) */
  recent: AlarmTransition[];
  /** a snapshot has arrived since the last (re)connection */
  live: boolean;
}

export const RECENT = 50;
export const SEVERITIES: Severity[] = ["low", "medium", "high", "critical"];
export const STATES: AlarmState[] = [
  "active_unacknowledged",
  "active_acknowledged",
  "cleared_unacknowledged",
  "shelved",
  "normal",
];

export function emptyView(): AlarmView {
  return {
    alarms: new Map(),
    counts: { active: 0, unacknowledged: 0, shelved: 0, highest: null },
    newest: null,
    segment: null,
    recent: [],
    live: false,
  };
}

/** The alarm raised last among those not shelved (what the Overview shows), as the agent picks it. */
export function newestOf(alarms: Iterable<AlarmPublic>): AlarmPublic | null {
  let best: AlarmPublic | null = null;
  for (const a of alarms)
    if (a.state !== "shelved" && a.raised && (!best || Date.parse(a.raised) > Date.parse(best.raised!))) best = a;
  return best;
}

/** `view` with one push message applied (a new object; the map is copied). */
export function applyPush(view: AlarmView, m: AlarmPush): AlarmView {
  if (m.snapshot) {
    const alarms = new Map(m.snapshot.alarms.map((a) => [a.key, a]));
    return {
      alarms,
      counts: m.snapshot.counts,
      newest: m.snapshot.newest ?? null,
      segment: m.snapshot.segment,
      recent: view.recent,
      live: true,
    };
  }
  const alarms = new Map(view.alarms);
  for (const a of m.changed ?? []) {
    if (a.state === "normal") alarms.delete(a.key);
    else alarms.set(a.key, a as AlarmPublic);
  }
  const recent = [...(m.transitions ?? [])].reverse().concat(view.recent).slice(0, RECENT);
  return { ...view, alarms, counts: m.counts ?? view.counts, newest: newestOf(alarms.values()), recent };
}

const rank = (s: string) => SEVERITIES.indexOf(s as Severity);

/** Those that need attention first: not shelved, unacknowledged, active, by severity, newest. */
export function sortedAlarms(alarms: Iterable<AlarmPublic>): AlarmPublic[] {
  const key = (a: AlarmPublic): [number, number, number, number, number] => [
    a.state === "shelved" ? 1 : 0,
    a.acknowledged ? 1 : 0,
    a.active ? 0 : 1,
    -rank(a.severity),
    -a.changed_ns,
  ];
  return [...alarms].sort((x, y) => {
    const a = key(x);
    const b = key(y);
    for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return a[i] - b[i];
    return x.key < y.key ? -1 : 1;
  });
}

export interface Banner {
  text: string;
  /** "bad": something high or critical waits for a person; "warn": anything else; "good": none */
  level: "bad" | "warn" | "good" | "muted";
  title: string;
}

/** What the banner in the bar says. */
export function bannerOf(view: AlarmView, connected: boolean): Banner {
  if (!connected || !view.live)
    return { text: "alarms: not connected", level: "muted", title: "the agent's alarm push is not connected" };
  const c = view.counts;
  const shelved = c.shelved ? ` · ${c.shelved} shelved` : "";
  if (!c.active && !c.unacknowledged)
    return { text: `no alarms${shelved}`, level: "good", title: "nothing needs attention" };
  const level = c.highest === "high" || c.highest === "critical" ? "bad" : "warn";
  return {
    text: `${c.active} active · ${c.unacknowledged} unacknowledged${shelved}`,
    level,
    title: `highest severity: ${c.highest ?? "–"}; open the Alarms page`,
  };
}

const STATE_TEXT: Record<string, string> = {
  active_unacknowledged: "active, unacknowledged",
  active_acknowledged: "active, acknowledged",
  cleared_unacknowledged: "cleared, unacknowledged",
  shelved: "shelved",
  normal: "normal",
  "": "",
};

export function stateText(state: string): string {
  return STATE_TEXT[state] ?? state;
}

/** The color of a state: unacknowledged ones are what an operator must look at. */
export function stateLevel(state: string): "bad" | "warn" | "muted" | "" {
  if (state === "active_unacknowledged") return "bad";
  if (state === "cleared_unacknowledged" || state === "active_acknowledged") return "warn";
  if (state === "shelved") return "muted";
  return "";
}

/** A datetime-local input's value (the browser's local time) as ISO 8601 UTC; undefined when empty or not a time. */
export function localToIso(value: string): string | undefined {
  if (!value.trim()) return undefined;
  const t = new Date(value);
  return Number.isNaN(t.getTime()) ? undefined : t.toISOString();
}

export interface HistoryForm {
  since: string;
  until: string;
  module: string;
  severity: string;
  state: string;
}

export interface HistoryQuery {
  since?: string;
  until?: string;
  module?: string;
  severity?: Severity;
  state?: AlarmState;
  limit?: number;
  offset?: number;
}

/** The history's query from the filter form: empty fields left out; a time that is not one is an error. */
export function historyQuery(
  form: HistoryForm,
  limit: number,
  offset: number,
): { ok: true; query: HistoryQuery } | { ok: false; error: string } {
  const query: HistoryQuery = { limit, offset };
  for (const which of ["since", "until"] as const) {
    if (!form[which].trim()) continue;
    const iso = localToIso(form[which]);
    if (!iso) return { ok: false, error: `"${form[which]}" is not a time (${which})` };
    query[which] = iso;
  }
  if (query.since && query.until && query.since > query.until)
    return { ok: false, error: "“since” is after “until”: nothing can match" };
  if (form.module.trim()) query.module = form.module.trim();
  if (form.severity) query.severity = form.severity as Severity;
  if (form.state) query.state = form.state as AlarmState;
  return { ok: true, query };
}

/** The CSV export's URL for the same filters (no paging: every row that matches). */
export function csvPath(q: HistoryQuery): string {
  const p = new URLSearchParams();
  for (const k of ["since", "until", "module", "severity", "state"] as const) if (q[k]) p.set(k, String(q[k]));
  const s = p.toString();
  return `/api/v1/alarms/history.csv${s ? `?${s}` : ""}`;
}

/** "41–60 of 230" for a history page. */
export function pageText(offset: number, shown: number, total: number): string {
  if (!total) return "no transitions";
  return `${offset + 1}–${offset + shown} of ${total}`;
}
