// csv.test.ts -- the CSV export of a plot's visible window.
import { describe, expect, it } from "vitest";
import { windowCsv } from "../../src/plot/csv";
import { SampleRing } from "../../src/plot/ring";

describe("windowCsv", () => {
  const r = new SampleRing(8, 2);
  const t = Float64Array.from({ length: 10 }, (_, k) => 100 + (k + 1) * 0.001);
  const a = Float64Array.from({ length: 10 }, (_, k) => k + 0.5);
  const b = Float64Array.from({ length: 10 }, (_, k) => (k === 6 ? NaN : -k));
  r.push(1, 1, t, [a, b]); // keeps seq 3..10

  it("holds exactly the samples in the x-range, with seq, t and one column per variable", () => {
    const text = windowCsv(r, ["x.a", "x.b[1]"], 100.005, 100.008).join("");
    expect(text).toBe(
      "seq,t,x.a,x.b[1]\n" +
        "5,100.005000000,4.5,-4\n" +
        "6,100.006000000,5.5,-5\n" +
        "7,100.007000000,6.5,\n" + // NaN: an empty field
        "8,100.008000000,7.5,-7\n",
    );
  });

  it("takes only what the ring still holds, and quotes names that need it", () => {
    const lines = windowCsv(r, ['odd,"name"', "b"], 0, 1e9).join("").trim().split("\n");
    expect(lines[0]).toBe('seq,t,"odd,""name""",b');
    expect(lines.length).toBe(9);
    expect(lines[1].startsWith("3,")).toBe(true);
    expect(lines[8].startsWith("10,")).toBe(true);
  });

  it("has just the header for an empty window", () => {
    expect(windowCsv(r, ["a", "b"], 5, 6).join("")).toBe("seq,t,a,b\n");
  });
});
