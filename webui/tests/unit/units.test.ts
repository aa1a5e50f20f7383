// units.test.ts -- periods typed by people, and durations, sizes and counts shown to them.
import { describe, expect, it } from "vitest";
import {
  formatBytes,
  formatCount,
  formatNs,
  formatPercent,
  formatUptime,
  parsePeriod,
  periodText,
} from "../../src/ops/units";

describe("parsePeriod", () => {
  it.each([
    ["10ms", 10_000_000],
    ["10 ms", 10_000_000],
    ["500us", 500_000],
    ["500 µs", 500_000],
    ["500μs", 500_000],
    ["100000", 100_000],
    ["100000ns", 100_000],
    ["1.5ms", 1_500_000],
    ["0.5 s", 500_000_000],
    ["2s", 2_000_000_000],
    [" 1MS ", 1_000_000],
    [".25ms", 250_000],
    ["1e6", 1_000_000],
  ])("%s is %d ns", (text, ns) => {
    expect(parsePeriod(text)).toEqual({ ok: true, ns });
  });

  it.each([
    ["", /empty/],
    ["0", /positive/],
    ["-1ms", /positive/],
    ["0ms", /positive/],
    ["1.5ns", /whole number of nanoseconds/],
    ["0.0000001ms", /whole number/],
    ["10 min", /unknown unit/],
    ["ten ms", /not a duration/],
    ["10 ms 5", /not a duration/],
    ["1e300s", /out of range/],
  ])("%j is refused", (text, message) => {
    const p = parsePeriod(text);
    expect(p.ok).toBe(false);
    if (!p.ok) expect(p.error).toMatch(message);
  });
});

describe("formatNs", () => {
  it.each([
    [10_000_000, "10 ms"],
    [1_500_000, "1.5 ms"],
    [100_000, "100 µs"],
    [999, "999 ns"],
    [0, "0"],
    [-24319.5, "−24.32 µs"],
    [2_000_000_000, "2 s"],
    [1234567, "1.235 ms"],
    [NaN, "–"],
    [null, "–"],
  ])("%s → %s", (ns, text) => {
    expect(formatNs(ns as number | null)).toBe(text);
  });
  it("rounds to the digits asked", () => {
    expect(formatNs(60_912, 3)).toBe("60.9 µs");
  });
});

describe("periodText", () => {
  it.each([
    [10_000_000, "10ms"],
    [1_500_000, "1.5ms"],
    [500_000, "500us"],
    [100_000, "100us"],
    [1_000_000_000, "1s"],
    [1_234_567, "1234567ns"],
    [750, "750ns"],
  ])("%d → %s, and parses back", (ns, text) => {
    expect(periodText(ns)).toBe(text);
    expect(parsePeriod(text)).toEqual({ ok: true, ns });
  });
});

describe("other formats", () => {
  it("uptime", () => {
    expect(formatUptime(5.23)).toBe("5.2 s");
    expect(formatUptime(3723)).toBe("01:02:03");
    expect(formatUptime(2 * 86400 + 5)).toBe("2 d 00:00:05");
    expect(formatUptime(-1)).toBe("–");
  });
  it("bytes", () => {
    expect(formatBytes(512)).toBe("512 B");
    expect(formatBytes(23e6)).toBe("21.9 MiB");
    expect(formatBytes(300 * 1024 * 1024)).toBe("300 MiB");
  });
  it("percent and count", () => {
    expect(formatPercent(0.1234)).toBe("12.3 %");
    expect(formatCount(1234567)).toBe("1\u2009234\u2009567");
    expect(formatCount(12)).toBe("12");
  });
});
