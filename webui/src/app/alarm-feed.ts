// alarm-feed.ts -- one WebSocket to /api/v1/alarms/live for the whole UI: the banner, the Alarms
// page and the Overview listen to the view it keeps (src/ops/alarms.ts).  It reconnects by itself;
// every (re)connection starts with a snapshot, so nothing is missed across a gap.
import { type AlarmPush, type AlarmView, applyPush, emptyView } from "../ops/alarms";

type Listener = (view: AlarmView, connected: boolean) => void;

export class AlarmFeed {
  private ws: WebSocket | null = null;
  private listeners = new Set<Listener>();
  private closed = false;
  private retry: ReturnType<typeof setTimeout> | null = null;
  view: AlarmView = emptyView();
  connected = false;
  error: string | null = null;
  /** the agent closed the feed because the session has ended (4401) */
  onSignedOut: () => void = () => {};

  /** `url`: ws(s)://.../api/v1/alarms/live; the browser signs it in with the session cookie. */
  constructor(private readonly url: string) {}

  /** Calls `fn` now and after every change; returns the function that stops it. */
  listen(fn: Listener): () => void {
    this.listeners.add(fn);
    if (!this.ws && !this.retry && !this.closed) this.connect();
    fn(this.view, this.connected);
    return () => this.listeners.delete(fn);
  }

  close(): void {
    this.closed = true;
    if (this.retry) clearTimeout(this.retry);
    this.ws?.close();
  }

  private connect(): void {
    const ws = new WebSocket(this.url);
    this.ws = ws;
    ws.onmessage = (ev) => {
      if (this.ws === ws && typeof ev.data === "string") this.handle(JSON.parse(ev.data) as AlarmPush);
    };
    ws.onopen = () => {
      if (this.ws !== ws) return;
      this.connected = true;
      this.error = null;
      this.emit();
    };
    ws.onclose = (ev) => {
      if (this.ws !== ws) return;
      this.ws = null;
      this.connected = false;
      this.view = { ...this.view, live: false };
      this.error = ev.code >= 4000 ? `alarms: ${ev.code} ${ev.reason}` : null;
      this.emit();
      if (ev.code === 4401 && !this.closed) this.onSignedOut();
      if (!this.closed && ev.code !== 4401 && ev.code !== 4403)
        this.retry = setTimeout(() => {
          this.retry = null;
          if (!this.closed) this.connect();
        }, 1000);
    };
  }

  /** Every message of the push, in one place. */
  private handle(m: AlarmPush): void {
    if (m.snapshot === undefined && m.transitions === undefined && m.counts === undefined) {
      console.warn("alarms: unknown message", m);
      return;
    }
    this.view = applyPush(this.view, m);
    this.emit();
  }

  private emit(): void {
    for (const l of this.listeners) l(this.view, this.connected);
  }
}
