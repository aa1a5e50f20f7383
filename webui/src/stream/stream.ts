// stream.ts -- one WebSocket to /api/v1/stream for the whole UI.  Pages subscribe to paths; the
// client asks the agent for the union and hands every listener the columns of its own paths.
// It reconnects by itself; `dropped` is the agent's exact counter of samples this client lost,
// `discarded` the samples that arrived but could not be handed on (a frame that does not decode or
// does not match the channels in force).
import { decodeFrame, FrameError } from "./frame";
import { FIELDS } from "./frame_spec";

export interface Samples {
  firstSeq: number;
  decimation: number;
  /** due times in seconds (CLOCK_MONOTONIC) */
  t: Float64Array;
  /** listener's paths → their column for these samples */
  values: Map<string, Float64Array>;
  /** samples lost by this connection so far */
  dropped: number;
}

export interface StreamStatus {
  connected: boolean;
  dropped: number;
  /** samples received but not handed to any listener (undecodable or mismatched frames) */
  discarded: number;
  basicPeriodNs: number | null;
  error: string | null;
}

type Listener = { paths: string[]; onSamples: (s: Samples) => void };

export class StreamClient {
  private ws: WebSocket | null = null;
  private listeners = new Set<Listener>();
  private channels: string[] = [];
  private closed = false;
  private retry: ReturnType<typeof setTimeout> | null = null;
  status: StreamStatus = { connected: false, dropped: 0, discarded: 0, basicPeriodNs: null, error: null };
  onStatus: (s: StreamStatus) => void = () => {};
  /** the agent closed the stream because the session has ended (4401) */
  onSignedOut: () => void = () => {};

  /** `url`: ws(s)://.../api/v1/stream; the browser signs it in with the session cookie. */
  constructor(
    private readonly url: string,
    private readonly decimation = 1,
  ) {}

  /** Starts delivering `paths` to `onSamples`; returns the function that stops it. */
  subscribe(paths: string[], onSamples: (s: Samples) => void): () => void {
    const l: Listener = { paths: [...paths], onSamples };
    this.listeners.add(l);
    this.resubscribe();
    return () => {
      this.listeners.delete(l);
      this.resubscribe();
    };
  }

  close(): void {
    this.closed = true;
    if (this.retry) clearTimeout(this.retry);
    this.ws?.close();
  }

  private union(): string[] {
    const all: string[] = [];
    for (const l of this.listeners) for (const p of l.paths) if (!all.includes(p)) all.push(p);
    return all;
  }

  private resubscribe(): void {
    if (this.closed) return;
    if (!this.ws) {
      if (!this.retry) this.connect(); // else the pending retry connects and subscribes
      return;
    }
    if (this.ws.readyState === WebSocket.OPEN)
      this.ws.send(JSON.stringify({ subscribe: this.union(), decimation: this.decimation, stats: true }));
  }

  private connect(): void {
    const ws = new WebSocket(this.url);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    ws.onopen = () => {
      if (this.ws !== ws) return;
      this.setStatus({ connected: true, error: null });
      this.resubscribe();
    };
    ws.onmessage = (ev) => {
      if (this.ws === ws) this.handle(ev.data);
    };
    ws.onclose = (ev) => {
      if (this.ws !== ws) return;
      this.ws = null;
      this.setStatus({ connected: false, error: ev.code >= 4000 ? `stream closed: ${ev.code} ${ev.reason}` : null });
      if (ev.code === 4401 && !this.closed) this.onSignedOut();
      if (!this.closed && ev.code !== 4401 && ev.code !== 4403)
        this.retry = setTimeout(() => {
          this.retry = null;
          if (!this.closed) this.connect();
        }, 1000);
    };
  }

  private handle(data: unknown): void {
    if (typeof data === "string") {
      const m = JSON.parse(data) as Record<string, unknown>;
      if ("channels" in m) {
        this.channels = (m.channels as { path: string }[]).map((c) => c.path);
        this.setStatus({ basicPeriodNs: Number(m.basic_period_ns) || null, error: null });
      } else if ("error" in m) {
        const e = m.error as { message?: string };
        this.setStatus({ error: e.message ?? "subscription refused" });
      } else if ("stats" in m) {
        const s = (m.stats as { stream?: { dropped?: number } }).stream;
        if (s?.dropped !== undefined) this.setStatus({ dropped: s.dropped });
      } else {
        console.warn("stream: unknown message", m);
      }
      return;
    }
    if (!(data instanceof ArrayBuffer)) return;
    let f: ReturnType<typeof decodeFrame>;
    try {
      f = decodeFrame(data);
    } catch (e) {
      if (!(e instanceof FrameError)) throw e;
      // the samples a refused frame carried, when its header got that far
      const count =
        data.byteLength >= FIELDS.count.offset + 4 ? new DataView(data).getUint32(FIELDS.count.offset, true) : 0;
      this.setStatus({ discarded: this.status.discarded + count, error: e.message });
      return;
    }
    if (f.channels !== this.channels.length) {
      // never expected: the agent sends a subscription's channels before its first frame
      this.setStatus({ discarded: this.status.discarded + f.count });
      return;
    }
    if (f.dropped !== this.status.dropped) this.setStatus({ dropped: f.dropped });
    const t = new Float64Array(f.count);
    for (let i = 0; i < f.count; i++) t[i] = f.t[i] / 1e9;
    for (const l of this.listeners) {
      const values = new Map<string, Float64Array>();
      for (const p of l.paths) {
        const c = this.channels.indexOf(p);
        if (c >= 0) values.set(p, f.columns[c]);
      }
      l.onSamples({ firstSeq: f.firstSeq, decimation: this.decimation, t, values, dropped: f.dropped });
    }
  }

  private setStatus(s: Partial<StreamStatus>): void {
    this.status = { ...this.status, ...s };
    this.onStatus(this.status);
  }
}
