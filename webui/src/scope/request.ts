// request.ts -- the Scope page's capture form as data: what is typed (strings, as typed), the
// capture request it makes (the agent's CaptureRequest, schema.d.ts), checked first against the
// limits GET /captures/limits answers (never a second copy of them), and the form a saved request
// fills in again.  The agent checks everything again; this only says early what to fix.
import type { components } from "../api/schema";
import { kindOf } from "../plot/vartypes";

type S = components["schemas"];
export type CaptureRequest = S["CaptureRequest"];
export type CaptureLimits = S["CaptureLimits"];
export type Trigger = CaptureRequest["trigger"];
export type Condition = Extract<Trigger, { kind: "condition" }>["conditions"][number];
export type Length = CaptureRequest["pre"];
export type Severity = NonNullable<Extract<Trigger, { kind: "alarm" }>["severity"]>;

export const TRIGGER_KINDS = ["condition", "alarm", "fault", "swap", "manual"] as const;
export type TriggerKind = (typeof TRIGGER_KINDS)[number];
export const SEVERITIES: Severity[] = ["low", "medium", "high", "critical"];
export const UNITS = ["rows", "ms", "s"] as const;
export type Unit = (typeof UNITS)[number];

export interface ConditionForm {
  kind: "edge" | "level" | "window";
  variable: string;
  direction: "rising" | "falling" | "either";
  threshold: string;
  compare: "above" | "below" | "equal";
  value: string;
  tolerance: string;
  where: "inside" | "outside";
  low: string;
  high: string;
  /** rows a level or window must hold */
  hold: string;
}

export interface CaptureForm {
  name: string;
  variables: string[];
  trigger: TriggerKind;
  combine: "and" | "or";
  conditions: ConditionForm[];
  alarmKey: string;
  alarmSeverity: Severity | "";
  pre: string;
  preUnit: Unit;
  post: string;
  postUnit: Unit;
  /** 1: single; N: N shots; 0: until disarmed */
  repeat: string;
}

export function emptyCondition(variable = ""): ConditionForm {
  return {
    kind: "edge",
    variable,
    direction: "rising",
    threshold: "0",
    compare: "above",
    value: "0",
    tolerance: "0",
    where: "inside",
    low: "0",
    high: "1",
    hold: "1",
  };
}

export function emptyForm(): CaptureForm {
  return {
    name: "",
    variables: [],
    trigger: "condition",
    combine: "and",
    conditions: [emptyCondition()],
    alarmKey: "",
    alarmSeverity: "",
    pre: "200",
    preUnit: "rows",
    post: "100",
    postUnit: "rows",
    repeat: "1",
  };
}

/** What the checks need besides the form: the limits (null until they came), the basic period
 * (to turn seconds into rows; null: unknown) and each variable's layout type (undefined: unknown). */
export interface CheckEnv {
  limits: CaptureLimits | null;
  basicPeriodNs: number | null;
  typeOf(path: string): string | undefined;
}

export type Built = { ok: true; request: CaptureRequest } | { ok: false; errors: string[] };

/** Whether a layout type can be a trigger's variable: a number or a bool (not a char). */
export function isNumeric(type: string | undefined): boolean {
  const k = type === undefined ? null : kindOf(type);
  return k !== null && k !== "char";
}

function num(text: string, what: string, errors: string[]): number {
  const t = text.trim();
  const v = t === "" ? Number.NaN : Number(t);
  if (!Number.isFinite(v)) errors.push(`${what}: "${text}" is not a number`);
  return v;
}

function int(text: string, what: string, lo: number, hi: number, errors: string[]): number {
  const v = num(text, what, errors);
  if (Number.isFinite(v) && (!Number.isInteger(v) || v < lo || v > hi))
    errors.push(`${what} must be a whole number from ${lo} to ${hi} (it is ${text.trim()})`);
  return v;
}

/** A length as the API takes it: {"rows"} or {"seconds"} (ms typed are sent as seconds). */
export function lengthOf(text: string, unit: Unit, what: string, errors: string[]): Length {
  const v = num(text, what, errors);
  if (Number.isFinite(v) && v < 0) errors.push(`${what} cannot be negative`);
  if (unit === "rows") {
    if (Number.isFinite(v) && !Number.isInteger(v)) errors.push(`${what} in rows must be a whole number`);
    return { rows: v };
  }
  return { seconds: unit === "ms" ? v / 1000 : v };
}

/** A length in rows of the basic period, rounded up as the agent rounds it (capture.py); null
 * when it is in seconds and the period is unknown. */
export function rowsOf(length: Length, basicPeriodNs: number | null): number | null {
  if (length.rows !== undefined && length.rows !== null) return length.rows;
  if (length.seconds === undefined || length.seconds === null || !basicPeriodNs) return null;
  return Math.ceil((length.seconds * 1e9) / basicPeriodNs - 1e-9);
}

/** The trigger's variables that are not among the captured ones: its extra channels, in order. */
export function triggerExtras(variables: readonly string[], trigger: Trigger): string[] {
  if (trigger.kind !== "condition") return [];
  const out: string[] = [];
  for (const c of trigger.conditions)
    if (!variables.includes(c.variable) && !out.includes(c.variable)) out.push(c.variable);
  return out;
}

function conditionOf(f: ConditionForm, i: number, env: CheckEnv, errors: string[]): Condition {
  const what = `condition ${i + 1}`;
  const variable = f.variable.trim();
  if (!variable) errors.push(`${what}: choose a variable`);
  else {
    const type = env.typeOf(variable);
    if (type === undefined) errors.push(`${what}: no variable "${variable}" in the running layout`);
    else if (!isNumeric(type)) errors.push(`${what}: ${variable} is a ${type}, not a number: a trigger needs a number`);
  }
  const maxHold = env.limits?.max_hold_rows ?? Number.MAX_SAFE_INTEGER;
  if (f.kind === "edge")
    return {
      kind: "edge",
      variable,
      direction: f.direction,
      threshold: num(f.threshold, `${what}'s threshold`, errors),
    };
  const hold_rows = int(f.hold, `${what}'s rows to hold`, 1, maxHold, errors);
  if (f.kind === "level") {
    const tolerance = f.compare === "equal" ? num(f.tolerance, `${what}'s tolerance`, errors) : 0;
    if (tolerance < 0) errors.push(`${what}'s tolerance cannot be negative`);
    return {
      kind: "level",
      variable,
      compare: f.compare,
      value: num(f.value, `${what}'s value`, errors),
      tolerance,
      hold_rows,
    };
  }
  const low = num(f.low, `${what}'s low`, errors);
  const high = num(f.high, `${what}'s high`, errors);
  if (low > high) errors.push(`${what}: the window's low (${low}) is above its high (${high})`);
  return { kind: "window", variable, where: f.where, low, high, hold_rows };
}

function triggerOf(form: CaptureForm, env: CheckEnv, errors: string[]): Trigger {
  switch (form.trigger) {
    case "condition": {
      const most = env.limits?.max_conditions ?? Number.MAX_SAFE_INTEGER;
      if (form.conditions.length === 0) errors.push("add a condition to the trigger");
      if (form.conditions.length > most)
        errors.push(`a trigger combines at most ${most} conditions (it has ${form.conditions.length})`);
      return {
        kind: "condition",
        combine: form.combine,
        conditions: form.conditions.map((c, i) => conditionOf(c, i, env, errors)),
      };
    }
    case "alarm": {
      const key = form.alarmKey.trim();
      return { kind: "alarm", key: key || null, severity: form.alarmSeverity || null };
    }
    default:
      return { kind: form.trigger };
  }
}

function periodText(ns: number): string {
  return ns >= 1e6 ? `${ns / 1e6} ms` : `${ns / 1e3} µs`;
}

/** The capture request the form asks for, or every reason it cannot be sent yet. */
export function buildRequest(form: CaptureForm, env: CheckEnv): Built {
  const errors: string[] = [];
  const L = env.limits;
  const variables = form.variables.map((v) => v.trim()).filter(Boolean);
  if (variables.length === 0) errors.push("choose at least one variable to capture (+ in the tree)");
  for (const v of variables) if (env.typeOf(v) === undefined) errors.push(`no variable "${v}" in the running layout`);
  const trigger = triggerOf(form, env, errors);
  const channels = variables.length + triggerExtras(variables, trigger).length;
  if (L && channels > L.max_channels)
    errors.push(
      `${channels} channels (${variables.length} variables and ${channels - variables.length} more of the trigger's): at most ${L.max_channels}`,
    );
  const pre = lengthOf(form.pre, form.preUnit, "pre-trigger", errors);
  const post = lengthOf(form.post, form.postUnit, "post-trigger", errors);
  const preRows = rowsOf(pre, env.basicPeriodNs);
  if (L && preRows !== null && preRows > L.max_pre_rows) {
    const at = env.basicPeriodNs ? ` (at the basic period of ${periodText(env.basicPeriodNs)})` : "";
    errors.push(
      `a pre-trigger of ${preRows} rows${at} is longer than the trace rings hold: at most ${L.max_pre_rows} rows`,
    );
  }
  const postRows = rowsOf(post, env.basicPeriodNs);
  if (L && postRows !== null && postRows > L.max_post_rows)
    errors.push(`a post-trigger of ${postRows} rows is more than ${L.max_post_rows}`);
  const repeat = int(form.repeat, "repeat", 0, L?.max_repeat ?? Number.MAX_SAFE_INTEGER, errors);
  const name = form.name.trim();
  if (L && name.length > L.max_name_chars) errors.push(`the name is longer than ${L.max_name_chars} characters`);
  if (errors.length) return { ok: false, errors };
  return { ok: true, request: { name, variables, trigger, pre, post, repeat } };
}

function text(v: number | null | undefined): string {
  return v === null || v === undefined ? "" : String(v);
}

function lengthForm(l: Length): [string, Unit] {
  if (l.rows !== undefined && l.rows !== null) return [String(l.rows), "rows"];
  const s = l.seconds ?? 0;
  if (s !== 0 && s < 1) return [String(Number((s * 1000).toPrecision(12))), "ms"];
  return [String(s), "s"];
}

/** The form a capture request fills in (a saved configuration restored, a capture armed again). */
export function formOf(r: CaptureRequest): CaptureForm {
  const f = emptyForm();
  f.name = r.name ?? "";
  f.variables = [...r.variables];
  f.trigger = r.trigger.kind;
  if (r.trigger.kind === "condition") {
    f.combine = r.trigger.combine ?? "and";
    f.conditions = r.trigger.conditions.map((c) => {
      const e = emptyCondition(c.variable);
      e.kind = c.kind;
      if (c.kind === "edge") {
        e.direction = c.direction ?? "rising";
        e.threshold = text(c.threshold ?? 0);
      } else if (c.kind === "level") {
        e.compare = c.compare;
        e.value = text(c.value);
        e.tolerance = text(c.tolerance ?? 0);
        e.hold = text(c.hold_rows ?? 1);
      } else {
        e.where = c.where ?? "inside";
        e.low = text(c.low);
        e.high = text(c.high);
        e.hold = text(c.hold_rows ?? 1);
      }
      return e;
    });
  } else f.conditions = [];
  if (r.trigger.kind === "alarm") {
    f.alarmKey = r.trigger.key ?? "";
    f.alarmSeverity = r.trigger.severity ?? "";
  }
  [f.pre, f.preUnit] = lengthForm(r.pre);
  [f.post, f.postUnit] = lengthForm(r.post);
  f.repeat = text(r.repeat ?? 1);
  return f;
}

/** A trigger in a few words, as the captures' list shows it. */
export function triggerText(t: Trigger): string {
  switch (t.kind) {
    case "condition": {
      const parts = t.conditions.map((c) => {
        if (c.kind === "edge") return `${c.variable} ${c.direction ?? "rising"} ${c.threshold ?? 0}`;
        const hold = (c.hold_rows ?? 1) > 1 ? ` for ${c.hold_rows}` : "";
        if (c.kind === "level")
          return `${c.variable} ${c.compare} ${c.value}${c.compare === "equal" ? ` ±${c.tolerance ?? 0}` : ""}${hold}`;
        return `${c.variable} ${c.where ?? "inside"} [${c.low}, ${c.high}]${hold}`;
      });
      return parts.join(t.combine === "or" ? " OR " : " AND ");
    }
    case "alarm":
      return `alarm ${[t.key, t.severity ? `${t.severity}+` : ""].filter(Boolean).join(" ") || "(any)"}`;
    default:
      return t.kind;
  }
}

/** A length as the list shows it: "200 rows", "1.5 s". */
export function lengthText(l: Length): string {
  if (l.rows !== undefined && l.rows !== null) return `${l.rows} rows`;
  const s = l.seconds ?? 0;
  return s < 1 && s !== 0 ? `${Number((s * 1000).toPrecision(12))} ms` : `${s} s`;
}
