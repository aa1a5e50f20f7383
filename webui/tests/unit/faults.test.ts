import { describe, expect, it } from "vitest";
import { faultSummary } from "../../src/ops/faults";

describe("faultSummary", () => {
  it("says none when irpd reports no fault", () => {
    expect(faultSummary({})).toEqual({ level: "good", text: "none" });
    expect(faultSummary({ stopped_by_fault: null, last_crash: null, left_out_after_crash: [] }).level).toBe("good");
  });
  it("puts a set stopped by a fault first", () => {
    const s = faultSummary({
      stopped_by_fault: "module 'hog' overran",
      left_out_after_crash: [{ module: "x", set: "/s" }],
    });
    expect(s).toEqual({ level: "bad", text: "set stopped: module 'hog' overran" });
  });
  it("names the modules a crash left out", () => {
    const s = faultSummary({
      left_out_after_crash: [
        { module: "a", set: "/s" },
        { module: "b", set: "/s" },
      ],
    });
    expect(s.level).toBe("warn");
    expect(s.text).toContain("a, b");
  });
  it("tells a restart after a crash whose module runs again", () => {
    const s = faultSummary({ last_crash: { signal: "SIGSEGV", module: "Robot", time: "2026-11-22T09:00:00Z" } });
    expect(s).toEqual({ level: "warn", text: "restarted after SIGSEGV in Robot at 2026-11-22T09:00:00Z" });
  });
  it("names the source line of the faulting instruction when the record has it", () => {
    const s = faultSummary({
      last_crash: { signal: "SIGSEGV", module: "Main", source: "main.st:12", time: "2026-11-22T09:00:00Z" },
    });
    expect(s.text).toBe("restarted after SIGSEGV in Main (main.st:12) at 2026-11-22T09:00:00Z");
  });
  it("names who sent the signal: systemd's watchdog, another process, irpd's own abort", () => {
    const at = { signal: "SIGABRT", time: "2026-11-22T09:00:00Z" };
    expect(faultSummary({ last_crash: { ...at, cause: "watchdog", sender_pid: 1 } }).text).toBe(
      "restarted after SIGABRT from systemd's watchdog at 2026-11-22T09:00:00Z",
    );
    expect(faultSummary({ last_crash: { ...at, cause: "signal", sender_pid: 4242 } }).text).toBe(
      "restarted after SIGABRT from pid 4242 at 2026-11-22T09:00:00Z",
    );
    expect(faultSummary({ last_crash: { ...at, cause: "abort", sender_pid: 7 } }).text).toBe(
      "restarted after SIGABRT (irpd's own abort) at 2026-11-22T09:00:00Z",
    );
  });
});
