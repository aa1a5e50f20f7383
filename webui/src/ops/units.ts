// units.ts -- durations, sizes and counts as people type and read them: "10ms", "500 us",
// "100000" (ns) in; "10 ms", "1.5 ms", "-24.3 µs", "12.4 MiB", "3 d 04:05:06" out.

const SCALE: Record<string, number> = {
  ns: 1,
  us: 1_000,
  µs: 1_000,
  μs: 1_000,
  ms: 1_000_000,
  s: 1_000_000_000,
};

export type Parsed = { ok: true; ns: number } | { ok: false; error: string };

/**
 * A period as typed: a number with an optional unit (ns, us/µs, ms, s); no unit means ns.
 * The result must be a whole, positive number of nanoseconds.
 */
export function parsePeriod(text: string): Parsed {
  const t = text.trim();
  if (t === "") return { ok: false, error: "empty: give a period such as 10ms, 500us or 100000 (ns)" };
  const m = /^([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:e[+-]?\d+)?)\s*([a-zµμ]*)$/i.exec(t);
  if (!m) return { ok: false, error: `"${t}" is not a duration; use e.g. 10ms, 500us or 100000 (ns)` };
  const unit = m[2].toLowerCase() || "ns";
  const scale = SCALE[unit];
  if (scale === undefined) return { ok: false, error: `unknown unit "${m[2]}"; use ns, us, ms or s` };
  const value = Number(m[1]) * scale;
  if (!Number.isFinite(value)) return { ok: false, error: `"${t}" is out of range` };
  const ns = Math.round(value);
  if (Math.abs(value - ns) > 1e-6 * Math.max(1, Math.abs(value)))
    return { ok: false, error: `${t} is not a whole number of nanoseconds` };
  if (ns <= 0) return { ok: false, error: "the period must be positive" };
  if (!Number.isSafeInteger(ns)) return { ok: false, error: `"${t}" is out of range` };
  return { ok: true, ns };
}

function trimNumber(v: number, digits: number): string {
  // at most `digits` significant digits, no trailing zeros, no exponent
  const s = Math.abs(v) >= 1000 ? v.toFixed(0) : v.toPrecision(digits);
  return s.includes(".") ? s.replace(/\.?0+$/, "") : s;
}

/**
 * A duration in the largest unit that keeps it ≥ 1: exact ("10 ms", "1.5 ms") when it fits in 4
 * significant digits, rounded to 3 otherwise.  NaN/null → "–".
 */
export function formatNs(ns: number | null | undefined, digits = 4): string {
  if (ns === null || ns === undefined || !Number.isFinite(ns)) return "–";
  if (ns === 0) return "0";
  const a = Math.abs(ns);
  const [scale, unit] = a >= 1e9 ? [1e9, "s"] : a >= 1e6 ? [1e6, "ms"] : a >= 1e3 ? [1e3, "µs"] : [1, "ns"];
  const sign = ns < 0 ? "−" : "";
  return `${sign}${trimNumber(a / scale, digits)} ${unit}`;
}

/** A period as it goes back into an edit field: exact, typable units ("10ms", "500us", "1500ns"). */
export function periodText(ns: number): string {
  // s and ms with up to three decimals, whole µs, else ns: 1.5ms, 250us, 1234567ns
  for (const [unit, scale, step] of [
    ["s", 1e9, 1e6],
    ["ms", 1e6, 1e3],
    ["us", 1e3, 1e3],
  ] as const)
    if (ns >= scale && ns % step === 0) return `${ns / scale}${unit}`;
  return `${ns}ns`;
}

/** Seconds as "3 d 04:05:06", "04:05:06" or "05.2 s" for short ones. */
export function formatUptime(seconds: number | null | undefined): string {
  if (seconds === null || seconds === undefined || !Number.isFinite(seconds) || seconds < 0) return "–";
  if (seconds < 60) return `${seconds.toFixed(1)} s`;
  const s = Math.floor(seconds);
  const d = Math.floor(s / 86400);
  const hh = String(Math.floor((s % 86400) / 3600)).padStart(2, "0");
  const mm = String(Math.floor((s % 3600) / 60)).padStart(2, "0");
  const ss = String(s % 60).padStart(2, "0");
  return `${d ? `${d} d ` : ""}${hh}:${mm}:${ss}`;
}

/** Bytes in binary units: "512 B", "12.4 MiB". */
export function formatBytes(n: number | null | undefined): string {
  if (n === null || n === undefined || !Number.isFinite(n)) return "–";
  const units = ["B", "KiB", "MiB", "GiB", "TiB"];
  let v = n;
  let i = 0;
  while (Math.abs(v) >= 1024 && i < units.length - 1) {
    v /= 1024;
    i++;
  }
  return i === 0 ? `${v} B` : `${v.toFixed(v >= 100 ? 0 : 1)} ${units[i]}`;
}

/** A fraction as a percentage: 0.123 → "12.3 %". */
export function formatPercent(f: number | null | undefined, digits = 1): string {
  if (f === null || f === undefined || !Number.isFinite(f)) return "–";
  return `${(f * 100).toFixed(digits)} %`;
}

/** A count with thin-space thousands: 1234567 → "1 234 567". */
export function formatCount(n: number | null | undefined): string {
  if (n === null || n === undefined || !Number.isFinite(n)) return "–";
  return Math.round(n)
    .toString()
    .replace(/\B(?=(\d{3})+(?!\d))/g, "\u2009");
}

/** Local time of an ISO timestamp with milliseconds: "14:03:07.412" (and the date when not today). */
export function formatTime(iso: string, now: Date = new Date()): string {
  const d = new Date(iso);
  if (Number.isNaN(d.getTime())) return iso;
  const hms = [d.getHours(), d.getMinutes(), d.getSeconds()].map((x) => String(x).padStart(2, "0")).join(":");
  const t = `${hms}.${String(d.getMilliseconds()).padStart(3, "0")}`;
  return d.toDateString() === now.toDateString() ? t : `${d.toISOString().slice(0, 10)} ${t}`;
}
