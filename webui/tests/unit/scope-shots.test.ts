// scope-shots.test.ts -- shots on the plot's axis: the time from each one's trigger row (0 at the
// trigger, exact whatever the decimation), overlaid shots merged on it with their series named
// apart and drawn from their own rows (sparse), how many rows to ask for, and the shot's line.
import { describe, expect, it } from "vitest";
import {
  everyFor,
  plotRows,
  relativeSeconds,
  type ShotRows,
  seriesNames,
  shotTag,
  summaryText,
} from "../../src/scope/shots";

function shot(
  first: number,
  n: number,
  trigger: number,
  every = 1,
  paths = ["SIG.wave[4]"],
  period = 1_000_000,
): ShotRows {
  const seq = Array.from({ length: Math.ceil(n / every) }, (_, k) => first + k * every);
  return {
    capture: "c1",
    summary: {
      shot: 1,
      trigger_seq: trigger,
      first_seq: first,
      last_seq: first + n - 1,
      pre_rows: trigger - first,
      post_rows: first + n - 1 - trigger,
      rows: n,
      drops: 0,
      cause: "condition",
      trigger_time_ns: 0,
      notes: [],
    },
    channels: paths.map((path) => ({ path, type: "double" })),
    basic_period_ns: period,
    seq,
    t_ns: seq.map((s) => 5e12 + s * period),
    columns: paths.map((_, c) => seq.map((s) => (s === first + 1 ? null : s * 10 + c))),
    every,
  };
}

describe("the time axis", () => {
  it("puts the trigger row at 0 and every row at (seq − trigger seq) × the basic period", () => {
    const t = relativeSeconds([98, 99, 100, 101], 100, 1_000_000);
    expect(Array.from(t)).toEqual([-0.002, -0.001, 0, 0.001]);
    // decimated rows that skip the trigger row keep their exact times
    expect(Array.from(relativeSeconds([97, 100, 103], 101, 100_000))).toEqual([-0.0004, -0.0001, 0.0002]);
  });

  it("asks for every n-th row only beyond a few million values", () => {
    expect(everyFor(17_385, 3)).toBe(1);
    expect(everyFor(1_000_000, 64)).toBe(32);
    expect(everyFor(10, 0)).toBe(1);
  });
});

describe("series names", () => {
  it("are the paths for one shot, and tagged with their shot for several (the same one twice made distinct)", () => {
    expect(seriesNames([{ tag: "sq#1", paths: ["a", "b"] }])).toEqual([["a", "b"]]);
    expect(
      seriesNames([
        { tag: "sq#2", paths: ["a"] },
        { tag: "sq#1", paths: ["a"] },
        { tag: "sq#1", paths: ["a"] },
      ]),
    ).toEqual([["sq#2: a"], ["sq#1: a"], ["sq#1 (2): a"]]);
    expect(shotTag({ id: "3f2a9c0d1b", name: " " }, 4)).toBe("3f2a9c0d1b#4");
    expect(shotTag({ id: "3f2a9c0d1b", name: "sq" }, 4)).toBe("sq#4");
  });
});

describe("plotRows", () => {
  it("gives one shot's rows with their seqs, NaN for null, the trigger marked at 0", () => {
    const rows = plotRows([{ rows: shot(10, 5, 12), tag: "sq#1" }]);
    expect(rows.names).toEqual(["SIG.wave[4]"]);
    expect(Array.from(rows.seq)).toEqual([10, 11, 12, 13, 14]);
    expect(Array.from(rows.t)).toEqual([-0.002, -0.001, 0, 0.001, 0.002]);
    expect(Array.from(rows.cols[0])).toEqual([100, Number.NaN, 120, 130, 140]);
    expect(rows.sparse).toBe(false);
    expect(rows.decimation).toBe(1);
    expect(rows.marks).toEqual([{ x: 0, label: "trigger" }]);
    expect(plotRows([{ rows: shot(10, 9, 12, 3), tag: "x" }]).decimation).toBe(3);
  });

  it("merges overlaid shots on the time from their own triggers, each series where its shot has rows", () => {
    // shot A: seq 10..15 (every row), trigger 12; shot B: seq 500..508 every 2nd, trigger 503
    const a = shot(10, 6, 12, 1, ["w"]);
    const b = shot(500, 9, 503, 2, ["w", "v"]);
    const rows = plotRows([
      { rows: a, tag: "sq#2" },
      { rows: b, tag: "sq#1" },
    ]);
    expect(rows.names).toEqual(["sq#2: w", "sq#1: w", "sq#1: v"]);
    expect(rows.sparse).toBe(true);
    // A at −2..3 ms, B at −3, −1, 1, 3, 5 ms: the union
    expect(Array.from(rows.t)).toEqual([-0.003, -0.002, -0.001, 0, 0.001, 0.002, 0.003, 0.005]);
    expect(Array.from(rows.seq)).toEqual([-3, -2, -1, 0, 1, 2, 3, 5]); // rows from the trigger
    const nan = Number.NaN;
    expect(Array.from(rows.cols[0])).toEqual([nan, 100, nan, 120, 130, 140, 150, nan]); // 11 was null
    expect(Array.from(rows.cols[1])).toEqual([5000, nan, 5020, nan, 5040, nan, 5060, 5080]);
    expect(Array.from(rows.cols[2])).toEqual([5001, nan, 5021, nan, 5041, nan, 5061, 5081]);
  });
});

describe("summaryText", () => {
  it("gives the trigger's seq, the pre and post counts, the drops and the cause", () => {
    const s = shot(10, 301, 210).summary;
    expect(summaryText(s)).toBe(
      "trigger seq 210 · 200 rows before, 100 after (301 rows, seq 10–310) · 0 dropped · cause: condition",
    );
    expect(summaryText(s, 4)).toContain("1 row in 4 shown");
  });
});
