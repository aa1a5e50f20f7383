// fake-socket.ts -- a WebSocket the tests play the agent's side of: what the client sent, and
// open / text / binary / drop to answer it; useFakeSocket() stubs it in as the global WebSocket
// (with fake timers, for the reconnections) around every test of the file or describe block.
import { afterEach, beforeEach, vi } from "vitest";

export function useFakeSocket(): void {
  beforeEach(() => {
    FakeSocket.all = [];
    vi.useFakeTimers();
    vi.stubGlobal("WebSocket", FakeSocket);
  });
  afterEach(() => {
    vi.useRealTimers();
    vi.unstubAllGlobals();
  });
}

export class FakeSocket {
  static OPEN = 1;
  static all: FakeSocket[] = [];
  readyState = 0;
  binaryType = "";
  sent: unknown[] = [];
  onopen: (() => void) | null = null;
  onmessage: ((ev: { data: unknown }) => void) | null = null;
  onclose: ((ev: { code: number; reason: string }) => void) | null = null;
  constructor(readonly url: string) {
    FakeSocket.all.push(this);
  }
  send(data: string) {
    this.sent.push(JSON.parse(data));
  }
  close() {
    this.readyState = 3;
    this.onclose?.({ code: 1000, reason: "" });
  }
  // the agent's side
  open() {
    this.readyState = 1;
    this.onopen?.();
  }
  text(m: unknown) {
    this.onmessage?.({ data: JSON.stringify(m) });
  }
  binary(b: ArrayBuffer) {
    this.onmessage?.({ data: b });
  }
  drop(code = 1006) {
    this.readyState = 3;
    this.onclose?.({ code, reason: "gone" });
  }
  get last() {
    return this.sent[this.sent.length - 1] as { subscribe: string[]; decimation: number };
  }
}
