// values.ts -- live values as the monitor (st_monitor.ts) and the Watch page (pages/watch.ts) show them
// (TRUE/FALSE coloured, numbers short) and the fixed-rate poller both refresh with; free of CodeMirror,
// so that the pages that do not edit do not load it.

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

/** Calls `fn` every `ms`, start to start (at once when a call took longer), never two at once, until
 * stopped; a throw goes to `onError` and the calls go on.  now(): the next call without waiting. */
export function pollAtRate(fn: () => Promise<unknown>, ms: number, onError: (e: unknown) => void) {
  let stopped = false;
  let timer: ReturnType<typeof setTimeout> | null = null;
  let running = false;
  const run = async () => {
    if (stopped || running) return;
    running = true;
    if (timer) clearTimeout(timer);
    const started = performance.now();
    try {
      await fn();
    } catch (e) {
      if (!stopped) onError(e);
    }
    running = false;
    if (!stopped) timer = setTimeout(() => void run(), Math.max(0, ms - (performance.now() - started)));
  };
  void run();
  return {
    stop() {
      stopped = true;
      if (timer) clearTimeout(timer);
    },
    now() {
      void run();
    },
  };
}
