// alarms.test.ts -- the alarms as the UI holds them: the view kept from the push (snapshot, then
// changes), the banner's words and color, the list's order, the history's filters and CSV path,
// and the feed's one WebSocket against a fake one (snapshot on every reconnection).
import { describe, expect, it, vi } from "vitest";
import { AlarmFeed } from "../../src/app/alarm-feed";
import {
  type AlarmView,
  applyPush,
  bannerOf,
  csvPath,
  emptyView,
  historyQuery,
  localToIso,
  newestOf,
  pageText,
  sortedAlarms,
  stateLevel,
} from "../../src/ops/alarms";
import type { AlarmCounts, AlarmTransition } from "../../src/ops/types";
import { alarm, counts, snapshot } from "./alarm-fixtures";
import { FakeSocket, useFakeSocket } from "./fake-socket";

function transition(seq: number, key: string, event: AlarmTransition["event"]): AlarmTransition {
  return {
    seq,
    time: "2026-11-26T10:00:01.000000Z",
    time_ns: 2_000,
    key,
    module: key.split("/")[0],
    id: key.split("/")[1],
    event,
    state: "active_unacknowledged",
    severity: "high",
    text: "",
    detail: "",
    value: 0,
    who: null,
    note: "",
    flags: [],
    count: 1,
  };
}

describe("the view", () => {
  it("is replaced by a snapshot and changed by pushes", () => {
    let v: AlarmView = applyPush(emptyView(), { snapshot: snapshot([alarm("PLC/8")], counts(1, 1)) });
    expect(v.live).toBe(true);
    expect([...v.alarms.keys()]).toEqual(["PLC/8"]);
    const robot = alarm("ROBOT/3", { raised: "2026-11-26T10:05:00.000000Z", changed_ns: 2_000 });
    v = applyPush(v, { transitions: [transition(7, "ROBOT/3", "raise")], changed: [robot], counts: counts(2, 2) });
    expect([...v.alarms.keys()].sort()).toEqual(["PLC/8", "ROBOT/3"]);
    expect(v.counts.active).toBe(2);
    expect(v.newest?.key).toBe("ROBOT/3");
    expect(v.recent.map((t) => t.seq)).toEqual([7]);
    // acknowledged and cleared: normal, gone from the list
    v = applyPush(v, {
      transitions: [transition(8, "ROBOT/3", "acknowledge"), transition(9, "ROBOT/3", "clear")],
      changed: [{ key: "ROBOT/3", state: "normal" }],
      counts: counts(1, 1),
    });
    expect([...v.alarms.keys()]).toEqual(["PLC/8"]);
    expect(v.newest?.key).toBe("PLC/8");
    expect(v.recent.map((t) => t.seq)).toEqual([9, 8, 7]);
  });

  it("keeps at most 50 recent transitions", () => {
    let v = applyPush(emptyView(), { snapshot: snapshot([], counts(0, 0)) });
    for (let i = 1; i <= 80; i++) v = applyPush(v, { transitions: [transition(i, "A/1", "raise")], changed: [] });
    expect(v.recent.length).toBe(50);
    expect(v.recent[0].seq).toBe(80);
  });

  it("does not take a shelved alarm for the newest", () => {
    const shelved = alarm("A/1", { state: "shelved", raised: "2026-11-26T11:00:00Z" });
    expect(newestOf([alarm("B/2"), shelved])?.key).toBe("B/2");
    expect(newestOf([shelved])).toBeNull();
  });
});

describe("the banner", () => {
  const live = (c: AlarmCounts) => applyPush(emptyView(), { snapshot: snapshot([], c) });

  it("counts active and unacknowledged alarms, red when something high waits", () => {
    expect(bannerOf(live(counts(2, 3, 0, "critical")), true)).toMatchObject({
      text: "2 active · 3 unacknowledged",
      level: "bad",
    });
    expect(bannerOf(live(counts(0, 1, 2, "low")), true)).toMatchObject({
      text: "0 active · 1 unacknowledged · 2 shelved",
      level: "warn",
    });
  });

  it("says when nothing needs attention, and when it does not know", () => {
    expect(bannerOf(live(counts(0, 0, 0, null)), true)).toMatchObject({ text: "no alarms", level: "good" });
    expect(bannerOf(live(counts(1, 1)), false)).toMatchObject({ text: "alarms: not connected", level: "muted" });
    expect(bannerOf(emptyView(), true).level).toBe("muted"); // connected, no snapshot yet
  });
});

describe("the list", () => {
  it("shows what needs attention first", () => {
    const list = sortedAlarms([
      alarm("ack/1", { acknowledged: true, state: "active_acknowledged" }),
      alarm("low/1", { severity: "low" }),
      alarm("shelved/1", { state: "shelved" }),
      alarm("cleared/1", { active: false, state: "cleared_unacknowledged", severity: "critical" }),
      alarm("crit/1", { severity: "critical", changed_ns: 5 }),
      alarm("crit/2", { severity: "critical", changed_ns: 9 }),
    ]).map((a) => a.key);
    expect(list).toEqual(["crit/2", "crit/1", "low/1", "cleared/1", "ack/1", "shelved/1"]);
  });

  it("colors unacknowledged states", () => {
    expect(stateLevel("active_unacknowledged")).toBe("bad");
    expect(stateLevel("cleared_unacknowledged")).toBe("warn");
    expect(stateLevel("normal")).toBe("");
  });
});

describe("the history's filters", () => {
  const form = { since: "", until: "", module: "", severity: "", state: "" };

  it("leave out what is empty", () => {
    expect(historyQuery(form, 50, 100)).toEqual({ ok: true, query: { limit: 50, offset: 100 } });
  });

  it("turn local times into UTC and keep the rest", () => {
    const since = "2026-11-26T08:30";
    const q = historyQuery({ ...form, since, module: " PLC ", severity: "high", state: "shelved" }, 50, 0);
    expect(q).toEqual({
      ok: true,
      query: {
        since: new Date(since).toISOString(),
        module: "PLC",
        severity: "high",
        state: "shelved",
        limit: 50,
        offset: 0,
      },
    });
    expect(localToIso("")).toBeUndefined();
  });

  it("refuse a window that ends before it begins", () => {
    const q = historyQuery({ ...form, since: "2026-11-26T09:00", until: "2026-11-26T08:00" }, 50, 0);
    expect(q).toEqual({ ok: false, error: "“since” is after “until”: nothing can match" });
  });

  it("give the CSV export the same filters without paging", () => {
    expect(csvPath({ module: "PLC", severity: "high", limit: 50, offset: 50 })).toBe(
      "/api/v1/alarms/history.csv?module=PLC&severity=high",
    );
    expect(csvPath({ limit: 50 })).toBe("/api/v1/alarms/history.csv");
    expect(pageText(50, 50, 230)).toBe("51–100 of 230");
    expect(pageText(0, 0, 0)).toBe("no transitions");
  });
});

describe("the feed", () => {
  useFakeSocket();

  it("opens one socket for every listener and hands each the view", () => {
    const feed = new AlarmFeed("ws://agent/api/v1/alarms/live");
    const a: string[] = [];
    const b: string[] = [];
    feed.listen((v, connected) => a.push(bannerOf(v, connected).text));
    feed.listen((v, connected) => b.push(bannerOf(v, connected).text));
    expect(FakeSocket.all.length).toBe(1);
    expect(FakeSocket.all[0].url).toBe("ws://agent/api/v1/alarms/live"); // the session cookie signs it in
    FakeSocket.all[0].open();
    FakeSocket.all[0].text({ snapshot: snapshot([alarm("PLC/8")], counts(1, 1)) });
    expect(a.at(-1)).toBe("1 active · 1 unacknowledged");
    expect(b.at(-1)).toBe("1 active · 1 unacknowledged");
  });

  it("reconnects and starts again from a snapshot; gives up when the session has ended", () => {
    const feed = new AlarmFeed("ws://agent/api/v1/alarms/live");
    let signedOut = 0;
    feed.onSignedOut = () => signedOut++;
    const seen: string[] = [];
    feed.listen((v, connected) => seen.push(bannerOf(v, connected).text));
    FakeSocket.all[0].open();
    FakeSocket.all[0].text({ snapshot: snapshot([alarm("PLC/8")], counts(1, 1)) });
    FakeSocket.all[0].drop();
    expect(seen.at(-1)).toBe("alarms: not connected");
    vi.advanceTimersByTime(1000);
    expect(FakeSocket.all.length).toBe(2);
    FakeSocket.all[1].open();
    FakeSocket.all[1].text({ snapshot: snapshot([], counts(0, 0, 0, null)) });
    expect(seen.at(-1)).toBe("no alarms");
    expect(signedOut).toBe(0);
    FakeSocket.all[1].drop(4401);
    vi.advanceTimersByTime(5000);
    expect(FakeSocket.all.length).toBe(2);
    expect(feed.error).toBe("alarms: 4401 gone");
    expect(signedOut).toBe(1);
  });

  it("logs a message it does not know and keeps the view", () => {
    const warn = vi.spyOn(console, "warn").mockImplementation(() => {});
    const feed = new AlarmFeed("ws://agent/api/v1/alarms/live");
    feed.listen(() => {});
    FakeSocket.all[0].text({ hello: 1 });
    expect(warn).toHaveBeenCalled();
    expect(feed.view.live).toBe(false);
    warn.mockRestore();
  });
});
