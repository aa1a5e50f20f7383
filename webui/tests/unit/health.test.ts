// health.test.ts -- GET /health read into ok / irpd down / agent down, and the banner.
import { describe, expect, it } from "vitest";
import { CounterWindow } from "../../src/ops/counters";
import { bannerText, classifyHealth, nextWatch } from "../../src/ops/health";

describe("classifyHealth", () => {
  it("ok", () => {
    expect(classifyHealth({ ok: true, status: 200, body: { agent: "ok", irpd: "ok", running: true } }).kind).toBe("ok");
  });
  it("irpd unreachable, with the agent's reason", () => {
    const s = classifyHealth({
      ok: true,
      status: 200,
      body: { agent: "ok", irpd: "unreachable", detail: "connection refused" },
    });
    expect(s).toMatchObject({ kind: "irpd-down", detail: "connection refused" });
  });
  it("the agent not answering: no connection, a timeout, or a proxy's error page", () => {
    expect(classifyHealth({ ok: false, error: "connection failed" }).kind).toBe("agent-down");
    expect(classifyHealth({ ok: true, status: 502, body: null }).kind).toBe("agent-down");
    expect(classifyHealth({ ok: true, status: 200, body: "<html>" }).kind).toBe("agent-down");
  });
});

describe("watch and banner", () => {
  it("no banner when ok; how long it has been down; back by itself", () => {
    const ok = classifyHealth({ ok: true, status: 200, body: { agent: "ok", irpd: "ok" } });
    const down = classifyHealth({
      ok: true,
      status: 200,
      body: { agent: "ok", irpd: "unreachable", detail: "no socket" },
    });
    let w = nextWatch(null, ok, 0);
    expect(bannerText(w, 0)).toBe("");
    w = nextWatch(w, down, 1000);
    w = nextWatch(w, down, 5000);
    expect(w.since).toBe(1000);
    expect(bannerText(w, 13_000)).toMatch(/^irpd is down or unreachable \(for 12 s\): no socket/);
    w = nextWatch(w, classifyHealth({ ok: false, error: "connection failed" }), 14_000);
    expect(bannerText(w, 14_000)).toMatch(/^The agent is unreachable \(for 0 s\): connection failed/);
    w = nextWatch(w, ok, 20_000);
    expect(w).toMatchObject({ previous: "agent-down", since: 20_000 });
    expect(bannerText(w, 20_000)).toBe("");
  });
});

describe("CounterWindow", () => {
  it("growth within the window; starts again when irpd restarts", () => {
    const c = new CounterWindow(10_000);
    expect(c.add(0, 5, 1)).toBe(0);
    expect(c.add(5_000, 7, 1)).toBe(2);
    expect(c.add(12_000, 9, 1)).toBe(2); // the sample at 0 left the window
    expect(c.add(13_000, 1, 2)).toBe(0); // another pid
    expect(c.add(14_000, 0, 2)).toBe(0); // went down: restarted
  });
});
