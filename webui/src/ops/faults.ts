// faults.ts -- the overview's "faults" line from irpd's status: a set stopped by a fault (an
// overrun with on_overrun=stop, docs/faults.md), modules a crash left out (docs/supervision.md),
// the crash irpd came back from (and who sent its signal: systemd's watchdog, a kill, irpd's abort;
// the source line of a fault, e.g. main.st:12).
import type { CrashRecord, Status } from "./types";

export interface FaultSummary {
  level: "good" | "warn" | "bad";
  text: string;
}

/** `st`: the status members it reads; an older irpd may lack them, or members of the crash record. */
export function faultSummary(
  st: Partial<Pick<Status, "stopped_by_fault" | "left_out_after_crash">> & { last_crash?: Partial<CrashRecord> | null },
): FaultSummary {
  if (st.stopped_by_fault) return { level: "bad", text: `set stopped: ${st.stopped_by_fault}` };
  const out = st.left_out_after_crash ?? [];
  if (out.length > 0) {
    const names = out.map((m) => m.module).join(", ");
    return { level: "warn", text: `left out after a crash: ${names} (enable, or clear_crash, to run again)` };
  }
  const c = st.last_crash;
  if (c) {
    const line = c.source ? ` (${c.source})` : "";
    const where = c.module ? ` in ${c.module}${line}` : line;
    const from =
      c.cause === "watchdog"
        ? " from systemd's watchdog"
        : c.cause === "signal"
          ? ` from pid ${c.sender_pid}`
          : c.cause === "abort"
            ? " (irpd's own abort)"
            : "";
    return {
      level: "warn",
      text: `restarted after ${c.signal ?? "a crash"}${from}${where}${c.time ? ` at ${c.time}` : ""}`,
    };
  }
  return { level: "good", text: "none" };
}
