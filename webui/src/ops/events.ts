// events.ts -- the live tail of GET /events: pages merged into one list, newest first, with the
// two cursors (irpd's `next`, the agent's `agent_next`) to ask only for newer events next time.
import type { AgentEvent, EventsPage } from "./types";

export interface Tail {
  /** newest first */
  events: AgentEvent[];
  since: number;
  agentSince: number;
  /** events lost before the cursors, summed over the pages */
  dropped: number;
  /** "ok", or why irpd's events are missing */
  irpd: string;
}

export function emptyTail(): Tail {
  return { events: [], since: 0, agentSince: 0, dropped: 0, irpd: "ok" };
}

/** The same event seen twice (a cursor reset after a restart) has the same key. */
export function eventKey(e: AgentEvent): string {
  return `${e.source}:${e.seq}:${e.time_ns}`;
}

/** `tail` with `page` merged in: no duplicates, newest first, at most `max` kept; the page's cursors. */
export function mergeEvents(tail: Tail, page: EventsPage, max = 500): Tail {
  const seen = new Set(tail.events.map(eventKey));
  const fresh = page.events.filter((e) => !seen.has(eventKey(e)) && (seen.add(eventKey(e)), true));
  const events = fresh.length
    ? [...fresh, ...tail.events]
        .sort((a, b) => b.time_ns - a.time_ns || (a.source === b.source ? b.seq - a.seq : 0))
        .slice(0, max)
    : tail.events;
  return {
    events,
    since: page.next,
    agentSince: page.agent_next,
    dropped: tail.dropped + page.dropped,
    irpd: page.irpd,
  };
}

/**
 * Cursors to start again from: irpd's after irpd restarted (its sequence numbers begin again),
 * the agent's after the agent restarted.  Events already shown are recognised by eventKey.
 */
export function resetCursors(tail: Tail, which: { irpd?: boolean; agent?: boolean }): Tail {
  return { ...tail, since: which.irpd ? 0 : tail.since, agentSince: which.agent ? 0 : tail.agentSince };
}

/** True when a page filled its limit for either source: there is more to fetch at once. */
export function pageFull(page: EventsPage, limit: number): boolean {
  let irpd = 0;
  let agent = 0;
  for (const e of page.events) e.source === "agent" ? agent++ : irpd++;
  return irpd >= limit || agent >= limit;
}

const BAD = new Set([
  "fault",
  "crash",
  "swap_failed",
  "process_exit",
  "irpd_lost",
  "restore_failed",
  "lockout",
  "stopped",
  "safe_outputs_failed",
  "process_hang",
]);
const WARN = new Set(["deadline", "overrun", "process_restart", "process_output_dropped", "rollback"]);

/** The state an event kind stands for: "bad", "warn" or "" (colors are for states only). */
export function eventLevel(kind: string): "bad" | "warn" | "" {
  return BAD.has(kind) ? "bad" : WARN.has(kind) ? "warn" : "";
}
