// line.ts -- the Line page's logic: GET /line's controllers as table rows (state and its colour,
// health, set, jitter, alarms, a link to each one's web UI), the summary line, and what to say when
// this controller's DDS bridge gives no view of the line.
import type { components } from "../api/schema";
import { formatNs, formatUptime } from "./units";

type S = components["schemas"];
export type LineView = S["LineView"];
export type LineController = S["LineController"];
export type LineState = LineController["state"];

/** The colour class of each state (ops.css): lost and fault are both red. */
export const STATE_CLASS: Record<LineState, string> = { ok: "good", warning: "warn", fault: "bad", lost: "bad" };

export interface LineRow {
  name: string;
  this: boolean;
  state: LineState;
  stateClass: string;
  /** why it is not ok, in words ("" when ok) */
  reasons: string;
  health: string;
  set: string;
  setTitle: string;
  jitter: string;
  alarms: string;
  alarmsTitle: string;
  uptime: string;
  seen: string;
  /** its web UI, only when it is an http(s) URL; null otherwise */
  link: string | null;
}

const HEALTH: Record<LineController["health"], string> = {
  running: "running",
  stopped: "stopped",
  fault: "fault",
  irpd_unreachable: "irpd unreachable",
};

/**
 * A controller's announced web UI as a link, or null.  Any controller on the domain can announce
 * anything: only an absolute http: or https: URL becomes a link.
 */
export function safeLink(url: string): string | null {
  if (!url) return null;
  try {
    const u = new URL(url);
    return u.protocol === "http:" || u.protocol === "https:" ? u.toString() : null;
  } catch {
    return null;
  }
}

function clock(unixSeconds: number): string {
  const d = new Date(unixSeconds * 1000);
  return [d.getHours(), d.getMinutes(), d.getSeconds()].map((n) => String(n).padStart(2, "0")).join(":");
}

export function lineRow(c: LineController): LineRow {
  const top = c.alarms[0];
  return {
    name: c.name,
    this: c.this,
    state: c.state,
    stateClass: STATE_CLASS[c.state],
    reasons: c.reasons.join("; "),
    health: HEALTH[c.health] + (c.health_detail ? `: ${c.health_detail}` : ""),
    set: c.set_name || "–",
    setTitle: [c.set_id && `set ${c.set_id}`, c.layout_hash && `layout ${c.layout_hash.slice(0, 16)}`]
      .filter(Boolean)
      .join(", "),
    jitter: c.jitter_p99_ns === null || c.jitter_p99_ns === undefined ? "–" : formatNs(c.jitter_p99_ns, 3),
    alarms: c.alarms_active ? `${c.alarms_active}${top ? ` (${top.severity})` : ""}` : "0",
    alarmsTitle: c.alarms.map((a) => `${a.severity} ${a.source}/${a.id}: ${a.text}`).join("\n"),
    uptime: c.uptime_ns ? formatUptime(c.uptime_ns / 1e9) : "–",
    seen: c.alive
      ? `${Math.round(c.age_s)} s ago`
      : `lost at ${clock(c.lost_since ?? c.last_seen)}, last seen ${clock(c.last_seen)}`,
    link: safeLink(c.agent_url),
  };
}

/** "3 controllers: 2 ok, 1 lost · domain 0 on lo", and the announcements the bridge did not list */
export function lineSummary(view: LineView): string {
  const n = view.controllers.length;
  const counts = (["ok", "warning", "fault", "lost"] as const)
    .map((s) => [s, view.controllers.filter((c) => c.state === s).length] as const)
    .filter(([, k]) => k > 0)
    .map(([s, k]) => `${k} ${s}`);
  const ignored = view.ignored ? ` · ${view.ignored} announcements ignored (bad names, or more than 256)` : "";
  return `${n} controller${n === 1 ? "" : "s"}${counts.length ? `: ${counts.join(", ")}` : ""} · domain ${view.domain_id} on ${view.interface}${ignored}`;
}

/** What the page says above the table: nothing when the bridge's view is current. */
export function lineNotice(view: LineView): { level: "" | "warn" | "bad"; text: string } {
  if (view.bridge === "ok") {
    if (!view.controllers.some((c) => c.this))
      return { level: "warn", text: `This controller (${view.this}) does not see its own announcement yet.` };
    return { level: "", text: "" };
  }
  // the agent's words say what happened and what to do
  const text = view.message ? view.message[0].toUpperCase() + view.message.slice(1) : `The line is ${view.bridge}.`;
  return { level: view.bridge === "off" ? "warn" : "bad", text };
}
