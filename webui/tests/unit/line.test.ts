// line.test.ts -- the Line page's logic: rows with state colours and words, links only to http(s)
// web UIs, the summary, and what the page says when the DDS bridge gives no view.
import { describe, expect, it } from "vitest";
import { type LineController, type LineView, lineNotice, lineRow, lineSummary, safeLink } from "../../src/ops/line";

function controller(over: Partial<LineController> = {}): LineController {
  return {
    name: "a",
    agent_url: "http://10.0.0.1:8080/",
    version: "0.1.0",
    set_name: "plc-robot/module.xml",
    set_id: "0123456789abcdef",
    layout_hash: "f".repeat(64),
    health: "running",
    health_detail: "",
    basic_period_ns: 10_000_000,
    jitter_p99_ns: 23_000,
    alarms_active: 0,
    alarms: [],
    uptime_ns: 3_725e9,
    period_s: 1,
    lease_s: 3,
    alive: true,
    last_seen: 1_700_000_000,
    lost_since: null,
    lost_reason: "",
    duplicate: false,
    state: "ok",
    reasons: [],
    this: false,
    age_s: 0.4,
    ...over,
  };
}

function view(over: Partial<LineView> = {}): LineView {
  return {
    bridge: "ok",
    message: "",
    this: "a",
    domain_id: 0,
    interface: "lo",
    age_s: 0.2,
    period_s: 1,
    ignored: 0,
    controllers: [controller({ this: true }), controller({ name: "b", state: "lost", alive: false })],
    ...over,
  };
}

describe("lineRow", () => {
  it("an ok controller: green, its figures and its link", () => {
    const r = lineRow(controller({ this: true }));
    expect(r).toMatchObject({
      stateClass: "good",
      this: true,
      jitter: "23 µs",
      alarms: "0",
      link: "http://10.0.0.1:8080/",
    });
    expect(r.uptime).toBe("01:02:05");
    expect(r.seen).toBe("0 s ago");
    expect(r.setTitle).toBe(`set 0123456789abcdef, layout ${"f".repeat(16)}`);
  });
  it("warning amber, fault and lost red, with why", () => {
    const warn = lineRow(
      controller({
        state: "warning",
        reasons: ["2 alarm(s) active, the highest high"],
        alarms_active: 2,
        alarms: [{ source: "main", id: 8, severity: "high", text: "drive lost" }],
      }),
    );
    expect(warn).toMatchObject({
      stateClass: "warn",
      alarms: "2 (high)",
      reasons: "2 alarm(s) active, the highest high",
    });
    expect(warn.alarmsTitle).toBe("high main/8: drive lost");
    expect(
      lineRow(controller({ state: "fault", health: "irpd_unreachable", health_detail: "no socket" })),
    ).toMatchObject({ stateClass: "bad", health: "irpd unreachable: no socket" });
    const lost = lineRow(controller({ state: "lost", alive: false, lost_since: 1_700_000_003 }));
    expect(lost.stateClass).toBe("bad");
    expect(lost.seen).toMatch(/^lost at \d\d:\d\d:\d\d, last seen \d\d:\d\d:\d\d$/);
    expect(lineRow(controller({ jitter_p99_ns: null, uptime_ns: 0 }))).toMatchObject({ jitter: "–", uptime: "–" });
  });
});

describe("safeLink", () => {
  it("only absolute http(s) URLs become links", () => {
    expect(safeLink("https://cell1:8443/")).toBe("https://cell1:8443/");
    expect(safeLink("javascript:alert(1)")).toBeNull();
    expect(safeLink("data:text/html,x")).toBeNull();
    expect(safeLink("cell1:8443")).toBeNull();
    expect(safeLink("")).toBeNull();
  });
});

describe("summary and notice", () => {
  it("counts the states", () => {
    expect(lineSummary(view())).toBe("2 controllers: 1 ok, 1 lost · domain 0 on lo");
    expect(lineSummary(view({ ignored: 3 }))).toMatch(/· 3 announcements ignored/);
  });
  it("nothing to say when the view is current and holds this controller", () => {
    expect(lineNotice(view())).toEqual({ level: "", text: "" });
    expect(lineNotice(view({ controllers: [] })).level).toBe("warn");
  });
  it("says the bridge is off, stopped or unreadable, with the agent's words", () => {
    const off = lineNotice(view({ bridge: "off", message: "the DDS bridge is not running", controllers: [] }));
    expect(off).toEqual({ level: "warn", text: "The DDS bridge is not running" });
    expect(lineNotice(view({ bridge: "stale", message: "the DDS bridge last wrote 9 s ago" }))).toEqual({
      level: "bad",
      text: "The DDS bridge last wrote 9 s ago",
    });
    expect(lineNotice(view({ bridge: "unreadable", message: "" })).text).toBe("The line is unreadable.");
  });
});
