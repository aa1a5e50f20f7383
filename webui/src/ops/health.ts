// health.ts -- is the agent up, and does irpd answer?  GET /health (no token) with a short
// timeout, read into one of three states, and how long the current one has lasted.
import type { Health } from "./types";

export type HealthKind = "ok" | "irpd-down" | "agent-down";

export interface HealthState {
  kind: HealthKind;
  /** what the agent said, when it answered */
  health: Health | null;
  /** why, when not ok */
  detail: string;
}

export type Probe = { ok: true; status: number; body: unknown } | { ok: false; error: string };

/** The state an answer (or its absence) means. */
export function classifyHealth(p: Probe): HealthState {
  if (!p.ok) return { kind: "agent-down", health: null, detail: p.error };
  const b = p.body as Partial<Health> | null;
  if (p.status !== 200 || !b || typeof b !== "object" || b.agent !== "ok")
    // a proxy's 502/504 or an error page: the agent itself is not answering
    return {
      kind: "agent-down",
      health: null,
      detail: `no answer from the agent (HTTP ${p.status}${p.status === 502 || p.status === 504 ? " from the proxy" : ""})`,
    };
  const health = b as Health;
  if (health.irpd !== "ok") return { kind: "irpd-down", health, detail: health.detail ?? `irpd ${health.irpd}` };
  return { kind: "ok", health, detail: "" };
}

/** GET /health, never throwing: a timeout or a refused connection is `{ok: false}`. */
export async function probeHealth(url = "api/v1/health", timeoutMs = 2500): Promise<Probe> {
  const ctl = new AbortController();
  const timer = setTimeout(() => ctl.abort(), timeoutMs);
  try {
    const r = await fetch(url, { signal: ctl.signal, cache: "no-store" });
    let body: unknown = null;
    try {
      body = await r.json();
    } catch {
      body = null;
    }
    return { ok: true, status: r.status, body };
  } catch {
    return { ok: false, error: ctl.signal.aborted ? `no answer within ${timeoutMs / 1000} s` : "connection failed" };
  } finally {
    clearTimeout(timer);
  }
}

export interface HealthWatch {
  state: HealthState;
  /** when the current kind began (ms since epoch) */
  since: number;
  /** the kind before the last change, null at first */
  previous: HealthKind | null;
}

/** The watch after one more probe: `since` moves only when the kind changes. */
export function nextWatch(w: HealthWatch | null, s: HealthState, now: number): HealthWatch {
  if (!w) return { state: s, since: now, previous: null };
  if (w.state.kind === s.kind) return { ...w, state: s };
  return { state: s, since: now, previous: w.state.kind };
}

/** The banner's text, or "" when all is well. */
export function bannerText(w: HealthWatch, now: number): string {
  const ago = Math.max(0, Math.round((now - w.since) / 1000));
  const dur = ago < 90 ? `${ago} s` : ago < 5400 ? `${Math.round(ago / 60)} min` : `${(ago / 3600).toFixed(1)} h`;
  switch (w.state.kind) {
    case "ok":
      return "";
    case "irpd-down":
      return `irpd is down or unreachable (for ${dur}): ${w.state.detail}. The agent reconnects by itself; figures below are stale.`;
    case "agent-down":
      return `The agent is unreachable (for ${dur}): ${w.state.detail}. Retrying every second; figures below are stale.`;
  }
}
