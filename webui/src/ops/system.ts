// system.ts -- what the System page computes without the DOM: the NDJSON log stream cut into lines,
// the lines kept while following, a restore's plan and a prune's report as sentences, and waiting
// for the agent to answer again after it restarted.
import type { components } from "../api/schema";
import { classifyHealth, type Probe, probeHealth } from "./health";
import { formatBytes } from "./units";

type S = components["schemas"];
export type SystemInfo = S["SystemInfo"];
export type LogLine = S["LogLine"];
export type LogPage = S["LogPage"];
export type RestorePlan = S["RestorePlan"];
export type PruneReport = S["PruneReport"];
export type TlsCertificate = S["TlsCertificate"];

/** The lines a followed log keeps on the page (the oldest go first). */
export const FOLLOW_KEEP = 2000;

/** Cuts a stream of newline-delimited JSON into objects, whatever the chunks' boundaries. */
export class NdjsonSplitter {
  private rest = "";
  push(text: string): unknown[] {
    this.rest += text;
    const lines = this.rest.split("\n");
    this.rest = lines.pop() ?? "";
    const out: unknown[] = [];
    for (const line of lines) {
      if (!line.trim()) continue;
      try {
        out.push(JSON.parse(line));
      } catch {
        // a line that is not JSON (a proxy's page cut in): skipped
      }
    }
    return out;
  }
}

/** `kept` with `more` appended, at most `keep` of the newest. */
export function appendLines<T>(kept: T[], more: T[], keep = FOLLOW_KEEP): T[] {
  const all = kept.concat(more);
  return all.length > keep ? all.slice(all.length - keep) : all;
}

/** The query a log read sends: empty fields left out, a local datetime-local value as UTC ISO. */
export function logQuery(
  lines: number,
  grep: string,
  sinceLocal: string,
): { lines: number; grep?: string; since?: string } {
  const q: { lines: number; grep?: string; since?: string } = { lines };
  if (grep.trim()) q.grep = grep.trim();
  if (sinceLocal) {
    const t = new Date(sinceLocal); // a datetime-local value is local time
    if (!Number.isNaN(t.getTime())) q.since = t.toISOString();
  }
  return q;
}

function change(c: { now?: number | string | null; after?: number | string | null }): string {
  const v = (x: number | string | null | undefined) => (x === null || x === undefined ? "none" : String(x));
  return c.now === c.after ? `${v(c.after)} (unchanged)` : `${v(c.now)} → ${v(c.after)}`;
}

/** A restore's plan as label/value rows for the review. */
export function planRows(p: RestorePlan): [string, string][] {
  const a = p.archive;
  return [
    [
      "backup",
      `of ${a.host ?? "?"}, ${a.created ?? "?"}, agent ${a.agent_version ?? "?"}: ${a.files} files, ${formatBytes(a.bytes)}${a.with_secrets ? ", with secrets" : ""}`,
    ],
    [
      "sets",
      `${p.sets.added.length} added, ${p.sets.present.length} already here, ${p.sets.kept.length} only here (kept)`,
    ],
    ["active set", change(p.active_set)],
    ["tokens", change(p.tokens)],
    ["users", change(p.users)],
    ["audit log lines", change(p.audit_lines)],
  ];
}

/** A prune's report in one sentence. */
export function pruneText(r: PruneReport): string {
  const verb = r.dry_run ? "would delete" : "deleted";
  return `${verb} ${r.deleted.length} set(s) and ${r.blobs.length} stored file(s), ${formatBytes(r.bytes)}; ${r.kept.length} set(s) kept`;
}

/** How a certificate's expiry reads, and whether to warn (30 days or less). */
export function expiryText(c: TlsCertificate): { text: string; level: "good" | "warn" | "bad" } {
  const days = c.days_left ?? 0;
  const until = c.not_after ? c.not_after.slice(0, 10) : "?";
  if (days < 0) return { text: `expired on ${until}`, level: "bad" };
  return { text: `until ${until} (${days} days)`, level: days <= 30 ? "warn" : "good" };
}

/**
 * Waits until the agent answers /health again after a restart: first until it stops answering
 * (or `downMs` passed: it may have been quick), then until it answers.  Resolves true when it is
 * back within `timeoutMs`.
 */
export async function waitForAgent(
  probe: () => Promise<Probe> = () => probeHealth(),
  timeoutMs = 60_000,
  stepMs = 500,
  downMs = 3000,
  sleep: (ms: number) => Promise<void> = (ms) => new Promise((r) => setTimeout(r, ms)),
): Promise<boolean> {
  let waited = 0;
  let wentDown = false;
  while (waited < timeoutMs) {
    const up = classifyHealth(await probe()).kind !== "agent-down";
    if (!up) wentDown = true;
    else if (wentDown || waited >= downMs) return true;
    await sleep(stepMs);
    waited += stepMs;
  }
  return false;
}
