// scope-request.test.ts -- the Scope page's capture form as data: the request built from what is
// typed (edge, level, window, an event; rows, ms and seconds), the checks made against the limits
// GET /captures/limits answers (and none without them), the trigger's extra channels, and the
// form a saved request fills in again.
import { describe, expect, it } from "vitest";
import {
  buildRequest,
  type CaptureForm,
  type CaptureLimits,
  type CheckEnv,
  emptyCondition,
  emptyForm,
  formOf,
  isNumeric,
  lengthText,
  rowsOf,
  triggerText,
} from "../../src/scope/request";

const TYPES: Record<string, string> = {
  "SIG.wave[4]": "double",
  "SIG.wave[0]": "double",
  "SIG.sample": "uint64_t",
  "SIG.on": "bool",
  "SIG.letter": "char",
};

const LIMITS: CaptureLimits = {
  max_channels: 3,
  max_conditions: 2,
  max_pre_rows: 200,
  ring_rows: 200,
  max_post_rows: 1000,
  max_hold_rows: 50,
  max_capture_bytes: 1 << 26,
  max_total_bytes: 1 << 28,
  max_armed: 8,
  max_captures: 64,
  max_shots_kept: 50,
  max_repeat: 10,
  event_lag_s: 2.5,
  max_name_chars: 8,
};

function env(limits: CaptureLimits | null = LIMITS, basicPeriodNs: number | null = 1_000_000): CheckEnv {
  return { limits, basicPeriodNs, typeOf: (p) => TYPES[p] };
}

function edgeForm(): CaptureForm {
  const f = emptyForm();
  f.variables = ["SIG.wave[4]", "SIG.wave[0]"];
  f.conditions = [{ ...emptyCondition("SIG.wave[4]"), threshold: "0.5" }];
  f.pre = "200";
  f.post = "100";
  return f;
}

function errorsOf(f: CaptureForm, e = env()): string[] {
  const b = buildRequest(f, e);
  if (b.ok) throw new Error("expected a refusal");
  return b.errors;
}

describe("buildRequest", () => {
  it("makes the capture request of a rising edge with pre and post in rows", () => {
    const b = buildRequest(edgeForm(), env());
    expect(b).toEqual({
      ok: true,
      request: {
        name: "",
        variables: ["SIG.wave[4]", "SIG.wave[0]"],
        trigger: {
          kind: "condition",
          combine: "and",
          conditions: [{ kind: "edge", variable: "SIG.wave[4]", direction: "rising", threshold: 0.5 }],
        },
        pre: { rows: 200 },
        post: { rows: 100 },
        repeat: 1,
      },
    });
  });

  it("takes a level and a window joined by OR, lengths in ms and s, and a repeat", () => {
    const f = edgeForm();
    f.combine = "or";
    f.conditions = [
      { ...emptyCondition("SIG.sample"), kind: "level", compare: "equal", value: "7", tolerance: "0.5", hold: "3" },
      { ...emptyCondition("SIG.wave[0]"), kind: "window", where: "outside", low: "-1", high: "1", hold: "2" },
    ];
    f.pre = "150";
    f.preUnit = "ms";
    f.post = "0.25";
    f.postUnit = "s";
    f.repeat = "0";
    const b = buildRequest(f, env());
    if (!b.ok) throw new Error(b.errors.join("; "));
    expect(b.request.trigger).toEqual({
      kind: "condition",
      combine: "or",
      conditions: [
        { kind: "level", variable: "SIG.sample", compare: "equal", value: 7, tolerance: 0.5, hold_rows: 3 },
        { kind: "window", variable: "SIG.wave[0]", where: "outside", low: -1, high: 1, hold_rows: 2 },
      ],
    });
    expect(b.request.pre).toEqual({ seconds: 0.15 });
    expect(b.request.post).toEqual({ seconds: 0.25 });
    expect(b.request.repeat).toBe(0);
  });

  it("makes an event's trigger: an alarm by key and severity, a fault, a manual one", () => {
    const f = edgeForm();
    f.trigger = "alarm";
    f.alarmKey = " main/8 ";
    f.alarmSeverity = "high";
    const a = buildRequest(f, env());
    expect(a.ok && a.request.trigger).toEqual({ kind: "alarm", key: "main/8", severity: "high" });
    f.alarmKey = "";
    f.alarmSeverity = "";
    const any = buildRequest(f, env());
    expect(any.ok && any.request.trigger).toEqual({ kind: "alarm", key: null, severity: null });
    f.trigger = "fault";
    const fault = buildRequest(f, env());
    expect(fault.ok && fault.request.trigger).toEqual({ kind: "fault" });
  });

  it("counts the trigger's variables that are not captured among the channels, against the limit", () => {
    const f = edgeForm();
    f.conditions = [emptyCondition("SIG.sample")]; // a third channel: 3 of 3
    expect(buildRequest(f, env()).ok).toBe(true);
    f.variables = ["SIG.wave[4]", "SIG.wave[0]", "SIG.on"];
    expect(errorsOf(f)).toEqual(["4 channels (3 variables and 1 more of the trigger's): at most 3"]);
  });

  it("refuses a pre-trigger longer than the rings hold, in rows or in seconds at the basic period", () => {
    const f = edgeForm();
    f.pre = "201";
    expect(errorsOf(f)).toEqual([
      "a pre-trigger of 201 rows (at the basic period of 1 ms) is longer than the trace rings hold: at most 200 rows",
    ]);
    f.pre = "0.2";
    f.preUnit = "s";
    expect(buildRequest(f, env()).ok).toBe(true); // 200 rows exactly, as the agent rounds it
    f.pre = "200.5";
    f.preUnit = "ms";
    expect(errorsOf(f)[0]).toContain("201 rows");
    // in seconds with no basic period known: the agent decides
    expect(buildRequest(f, env(LIMITS, null)).ok).toBe(true);
  });

  it("takes every other limit from GET /captures/limits and checks none without them", () => {
    const f = edgeForm();
    f.conditions = [emptyCondition("SIG.wave[4]"), emptyCondition("SIG.wave[4]"), emptyCondition("SIG.wave[4]")];
    f.conditions[0] = { ...f.conditions[0], kind: "level", hold: "51" };
    f.post = "1001";
    f.repeat = "11";
    f.name = "too long a name";
    expect(errorsOf(f)).toEqual([
      "a trigger combines at most 2 conditions (it has 3)",
      "condition 1's rows to hold must be a whole number from 1 to 50 (it is 51)",
      "a post-trigger of 1001 rows is more than 1000",
      "repeat must be a whole number from 0 to 10 (it is 11)",
      "the name is longer than 8 characters",
    ]);
    expect(buildRequest(f, env(null)).ok).toBe(true);
  });

  it("says what to fix in what is typed: no variable, an unknown or non-numeric trigger variable, text, a window upside down", () => {
    const f = edgeForm();
    f.variables = [];
    f.conditions = [
      { ...emptyCondition("SIG.letter") },
      { ...emptyCondition("SIG.nothing"), kind: "window", low: "2", high: "1" },
    ];
    f.post = "lots";
    expect(errorsOf(f, env(null))).toEqual([
      "choose at least one variable to capture (+ in the tree)",
      "condition 1: SIG.letter is a char, not a number: a trigger needs a number",
      'condition 2: no variable "SIG.nothing" in the running layout',
      "condition 2: the window's low (2) is above its high (1)",
      'post-trigger: "lots" is not a number',
    ]);
    f.variables = ["SIG.wave[4]"];
    f.conditions = [];
    f.post = "100";
    expect(errorsOf(f, env(null))).toEqual(["add a condition to the trigger"]);
  });
});

describe("formOf", () => {
  it("fills the form with a saved request, which builds the same request again", () => {
    const f = edgeForm();
    f.name = "sq";
    f.combine = "or";
    f.conditions.push({ ...emptyCondition("SIG.sample"), kind: "level", compare: "below", value: "3", hold: "4" });
    f.pre = "150";
    f.preUnit = "ms";
    f.post = "0.5";
    f.postUnit = "s";
    f.repeat = "3";
    const first = buildRequest(f, env());
    if (!first.ok) throw new Error(first.errors.join("; "));
    const again = formOf(first.request);
    expect(again.pre).toBe("150");
    expect(again.preUnit).toBe("ms");
    expect(again.conditions[1]).toMatchObject({ kind: "level", compare: "below", value: "3", hold: "4" });
    expect(buildRequest(again, env())).toEqual(first);
  });

  it("takes the answers' nulls for lengths (a saved configuration as the agent answers it)", () => {
    const f = formOf({
      name: "",
      variables: ["SIG.wave[4]"],
      trigger: { kind: "manual" },
      pre: { rows: 10, seconds: null },
      post: { rows: null, seconds: 0.5 },
      repeat: 1,
    });
    expect([f.pre, f.preUnit, f.post, f.postUnit, f.trigger]).toEqual(["10", "rows", "500", "ms", "manual"]);
    expect(f.conditions).toEqual([]);
  });
});

describe("words", () => {
  it("says a trigger and a length in a few words", () => {
    const f = edgeForm();
    f.combine = "or";
    f.conditions.push({ ...emptyCondition("SIG.wave[0]"), kind: "window", low: "-1", high: "1", hold: "5" });
    const b = buildRequest(f, env());
    if (!b.ok) throw new Error(b.errors.join("; "));
    expect(triggerText(b.request.trigger)).toBe("SIG.wave[4] rising 0.5 OR SIG.wave[0] inside [-1, 1] for 5");
    expect(triggerText({ kind: "alarm", key: "main/8", severity: "high" })).toBe("alarm main/8 high+");
    expect(lengthText({ rows: 200 })).toBe("200 rows");
    expect(lengthText({ seconds: 0.1 })).toBe("100 ms");
    expect(lengthText({ seconds: 2 })).toBe("2 s");
  });

  it("knows which layout types can trigger", () => {
    expect(["double", "float", "uint64_t", "int16_t", "bool"].every(isNumeric)).toBe(true);
    expect(isNumeric("char")).toBe(false);
    expect(isNumeric("struct Foo")).toBe(false);
    expect(isNumeric(undefined)).toBe(false);
    expect(rowsOf({ seconds: 0.0101 }, 1_000_000)).toBe(11);
    expect(rowsOf({ seconds: 0.1 }, 1_000_000)).toBe(100); // 100.00000000000001 rounds as the agent does
  });
});
