// alarm-fixtures.ts -- alarms and snapshots as the agent sends them, for the alarm tests.
import { type AlarmView, applyPush, emptyView, newestOf } from "../../src/ops/alarms";
import type { AlarmCounts, AlarmList, AlarmPublic } from "../../src/ops/types";

/** An active, unacknowledged, high alarm `key` ("PLC/8"), with `over` changed. */
export function alarm(key: string, over: Partial<AlarmPublic> = {}): AlarmPublic {
  const [module, id] = key.split("/");
  return {
    key,
    module,
    id,
    origin: "module",
    state: "active_unacknowledged",
    condition: "active_unacknowledged",
    severity: "high",
    text: `text of ${key}`,
    detail: "",
    value: 0,
    flags: [],
    active: true,
    acknowledged: false,
    raises: 1,
    changed: "2026-11-26T10:00:00.000000Z",
    changed_ns: 1_000,
    raised: "2026-11-26T10:00:00.000000Z",
    cleared: null,
    acknowledged_at: null,
    acknowledged_by: null,
    confirmed: false,
    confirmed_at: null,
    confirmed_by: null,
    shelved_at: null,
    shelved_until: null,
    shelved_by: null,
    shelve_reason: null,
    ...over,
  };
}

export function counts(
  active: number,
  unacknowledged: number,
  shelved = 0,
  highest: AlarmCounts["highest"] = "high",
): AlarmCounts {
  return { active, unacknowledged, shelved, highest };
}

export function snapshot(alarms: AlarmPublic[], c: AlarmCounts): AlarmList {
  return {
    alarms,
    counts: c,
    newest: newestOf(alarms),
    segment: { name: "/indurop.t.alarms", error: null, lost: 0, abandoned: 0, suppressed: 0, sources: [] },
  };
}

/** The view after the snapshot of `alarms` (all of them active and unacknowledged). */
export function live(alarms: AlarmPublic[]): AlarmView {
  return applyPush(emptyView(), { snapshot: snapshot(alarms, counts(alarms.length, alarms.length)) });
}
