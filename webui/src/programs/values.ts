// values.ts -- live values as the monitor (st_monitor.ts) and the Watch page (pages/watch.ts) show them
// (TRUE/FALSE coloured, numbers short) and how often they refresh; free of CodeMirror, so that the pages
// that do not edit do not load it.

export type Value = boolean | number | null | undefined;
export const MONITOR_MS = 200; // >= 5 Hz

/** A value as the monitor shows it: TRUE/FALSE, an integer, a real with up to 6 significant digits. */
export function valueText(v: Value): string {
  if (v === null || v === undefined) return "?";
  if (typeof v === "boolean") return v ? "TRUE" : "FALSE";
  if (Number.isInteger(v)) return String(v);
  return String(Number(v.toPrecision(6)));
}

/** The CSS class of a value: st-mon-true / st-mon-false for a BOOL, st-mon-num otherwise. */
export function valueClass(v: Value, forced = false): string {
  const kind = typeof v === "boolean" ? (v ? "st-mon-true" : "st-mon-false") : "st-mon-num";
  return `st-mon ${kind}${forced ? " st-mon-forced" : ""}`;
}
