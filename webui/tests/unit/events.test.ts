// events.test.ts -- the event tail: pages merged newest first with both cursors, no duplicates
// after a cursor reset, a bounded length.
import { describe, expect, it } from "vitest";
import { emptyTail, eventLevel, mergeEvents, pageFull, resetCursors } from "../../src/ops/events";
import type { AgentEvent, EventsPage } from "../../src/ops/types";

const ev = (source: "irpd" | "agent", seq: number, t: number, kind = "start"): AgentEvent => ({
  source,
  seq,
  time_ns: t,
  time: new Date(t / 1e6).toISOString(),
  kind,
  module: null,
  message: `${source} ${seq}`,
});

const page = (events: AgentEvent[], next: number, agent_next: number, dropped = 0, irpd = "ok"): EventsPage => ({
  events,
  next,
  agent_next,
  dropped,
  irpd,
});

describe("mergeEvents", () => {
  it("newest first, with the page's cursors", () => {
    let tail = mergeEvents(emptyTail(), page([ev("irpd", 1, 100), ev("agent", 1, 150), ev("irpd", 2, 200)], 2, 2));
    expect(tail.events.map((e) => e.message)).toEqual(["irpd 2", "agent 1", "irpd 1"]);
    expect([tail.since, tail.agentSince]).toEqual([2, 2]);
    tail = mergeEvents(tail, page([ev("agent", 2, 250)], 2, 3));
    expect(tail.events.map((e) => e.message)).toEqual(["agent 2", "irpd 2", "agent 1", "irpd 1"]);
    expect([tail.since, tail.agentSince]).toEqual([2, 3]);
  });

  it("an empty page keeps the list and moves nothing but the cursors", () => {
    const a = mergeEvents(emptyTail(), page([ev("irpd", 1, 100)], 1, 1));
    const b = mergeEvents(a, page([], 1, 1));
    expect(b.events).toBe(a.events);
  });

  it("the same events again (after a cursor reset) are not shown twice", () => {
    const a = mergeEvents(emptyTail(), page([ev("irpd", 1, 100), ev("irpd", 2, 200)], 2, 1));
    const reset = resetCursors(a, { irpd: true });
    expect(reset.since).toBe(0);
    expect(reset.agentSince).toBe(1);
    const b = mergeEvents(reset, page([ev("irpd", 1, 100), ev("irpd", 2, 200), ev("irpd", 3, 300)], 3, 1));
    expect(b.events.map((e) => e.seq)).toEqual([3, 2, 1]);
  });

  it("a restarted irpd's seq 1 is a new event (another time)", () => {
    const a = mergeEvents(emptyTail(), page([ev("irpd", 1, 100)], 1, 1));
    const b = mergeEvents(resetCursors(a, { irpd: true }), page([ev("irpd", 1, 900)], 1, 1));
    expect(b.events.map((e) => e.time_ns)).toEqual([900, 100]);
  });

  it("keeps at most `max`, dropping the oldest; sums what was lost", () => {
    let tail = emptyTail();
    for (let i = 1; i <= 5; i++) tail = mergeEvents(tail, page([ev("irpd", i, i * 10)], i, 1, i === 3 ? 7 : 0), 3);
    expect(tail.events.map((e) => e.seq)).toEqual([5, 4, 3]);
    expect(tail.dropped).toBe(7);
  });

  it("says why irpd's events are missing", () => {
    const t = mergeEvents(
      emptyTail(),
      page([ev("agent", 1, 1, "irpd_lost")], 0, 2, 0, "unavailable: connection refused"),
    );
    expect(t.irpd).toBe("unavailable: connection refused");
  });
});

describe("helpers", () => {
  it("a full page means more to fetch", () => {
    expect(pageFull(page([ev("irpd", 1, 1), ev("irpd", 2, 2)], 2, 1), 2)).toBe(true);
    expect(pageFull(page([ev("irpd", 1, 1), ev("agent", 2, 2)], 2, 1), 2)).toBe(false);
  });
  it("event kinds as states", () => {
    expect(eventLevel("fault")).toBe("bad");
    expect(eventLevel("deadline")).toBe("warn");
    expect(eventLevel("swap")).toBe("");
  });
});
