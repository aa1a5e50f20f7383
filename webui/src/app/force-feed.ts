// force-feed.ts -- the forces irpd holds (GET /api/v1/forces), polled once for the whole UI by the
// shell: the banner on every page, the Forces page and the Variables page listen to it instead of
// polling themselves; a force or an unforce made through it (force(), unforce()) looks again at once.
import type { Api } from "../api/client";
import { unwrap } from "../api/client";
import type { components } from "../api/schema";
import { errorText, poll } from "../ops/dom";

export type Force = components["schemas"]["Force"];
type Listener = (forces: readonly Force[], error: string | null) => void;

export const FORCE_POLL_MS = 2000;

export class ForceFeed {
  forces: Force[] = [];
  error: string | null = null;
  private listeners = new Set<Listener>();
  private poller: ReturnType<typeof poll> | null = null;

  constructor(private readonly api: Api) {}

  /** Calls `fn` now and after every poll; returns the function that stops it. */
  listen(fn: Listener): () => void {
    this.listeners.add(fn);
    this.poller ??= poll(
      () => this.read(),
      FORCE_POLL_MS,
      (e) => this.emit(this.forces, errorText(e)),
    );
    fn(this.forces, this.error);
    return () => this.listeners.delete(fn);
  }

  /** Looks again now (after a force or an unforce made here). */
  refresh(): void {
    this.poller?.now();
  }

  /** Forces `path` to `value` (PUT /forces/{path}, operator) and looks again; says what was done. */
  async force(path: string, value: number | boolean): Promise<string> {
    try {
      const f = unwrap(await this.api.PUT("/api/v1/forces/{path}", { params: { path: { path } }, body: { value } }));
      return `${f.path} forced to ${String(f.value)}`;
    } finally {
      this.refresh();
    }
  }

  /** Unforces `path`, keeping the forced value or restoring the one before, and looks again. */
  async unforce(path: string, restore: boolean): Promise<string> {
    try {
      const r = unwrap(
        await this.api.DELETE("/api/v1/forces/{path}", { params: { path: { path }, query: { restore } } }),
      );
      return `${path} unforced, ${restore ? "restored to" : "left at"} ${String(r.left)}`;
    } finally {
      this.refresh();
    }
  }

  /** The force of `path`, if it is forced. */
  of(path: string): Force | undefined {
    return this.forces.find((f) => f.path === path);
  }

  private async read(): Promise<void> {
    if (document.hidden) return; // a tab in the background: the next poll after it shows
    const r = unwrap(await this.api.GET("/api/v1/forces"));
    this.emit(r.forces, null);
  }

  private emit(forces: Force[], error: string | null): void {
    this.forces = forces;
    this.error = error;
    for (const l of this.listeners) l(forces, error);
  }
}

/** When a force was set, in the browser's local time. */
export function forcedSince(f: Force): string {
  return new Date(f.since_ns / 1e6).toLocaleString();
}

/** The banner's text: "1 force active", "3 forces active" (empty with none). */
export function bannerText(n: number): string {
  return n === 0 ? "" : `${n} force${n === 1 ? "" : "s"} active`;
}

/** Who forced what and when, one line a force (the banner's title). */
export function forcesTitle(forces: readonly Force[]): string {
  return forces.map((f) => `${f.path} = ${String(f.value)} (forced by ${f.by}, ${forcedSince(f)})`).join("\n");
}
