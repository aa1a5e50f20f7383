// programs.test.ts -- the Programs page's pure parts: the blocks that fold (from the grammar's END_
// keywords), completion and hover from the check's symbols, the check's errors as editor ranges,
// the check's errors listed as an upload's are, and a diff's lines.
import { describe, expect, it } from "vitest";
import { problemList } from "../../src/ops/problems-view";
import { ST_KEYWORDS } from "../../src/programs/st_language";
import { complete, hoverText, type Symbols } from "../../src/programs/st_symbols";
import { BLOCKS, blocks, diagnostics, foldRanges, words } from "../../src/programs/st_text";
import { diffLines } from "../../src/programs/st_view";

const SOURCE = `PROGRAM Counter
VAR
  count : DINT; (* IF in a comment END_IF *)
  t : TON;
END_VAR
IF count > 10 THEN
  count := 0; // END_IF in a comment
END_IF;
t(IN := TRUE, PT := T#1s);
END_PROGRAM
CONFIGURATION Cell
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#1ms);
    PROGRAM Main WITH Fast : Counter;
  END_RESOURCE
END_CONFIGURATION
`;

const SYMBOLS: Symbols = {
  pous: [
    {
      name: "Counter",
      kind: "PROGRAM",
      file: "main.st",
      line: 1,
      vars: [
        { name: "count", kind: "VAR", type: "DINT", line: 3, constant: false, paths: ["Main.count"] },
        { name: "t", kind: "VAR", type: "TON", line: 4, constant: false, paths: ["Main.t"] },
      ],
    },
  ],
  globals: [],
  fb_types: [
    {
      name: "TON",
      library: true,
      params: [
        { name: "IN", kind: "VAR_INPUT", type: "BOOL" },
        { name: "PT", kind: "VAR_INPUT", type: "TIME" },
        { name: "Q", kind: "VAR_OUTPUT", type: "BOOL" },
        { name: "ET", kind: "VAR_OUTPUT", type: "TIME" },
      ],
    },
  ],
  functions: [
    {
      name: "LIMIT",
      kind: "function",
      result: "T",
      params: [
        { name: "MN", type: "ANY_ELEMENTARY" },
        { name: "IN", type: "ANY_ELEMENTARY" },
        { name: "MX", type: "ANY_ELEMENTARY" },
      ],
      extensible: false,
    },
  ],
};

describe("blocks and folding", () => {
  it("takes its openers and closers from the grammar's keywords", () => {
    expect(BLOCKS.get("FUNCTION_BLOCK")).toBe("END_FUNCTION_BLOCK");
    expect(BLOCKS.get("IF")).toBe("END_IF");
    expect(BLOCKS.get("VAR_INPUT")).toBe("END_VAR");
    for (const closer of BLOCKS.values()) expect(ST_KEYWORDS).toContain(closer);
  });

  it("skips comments and strings and matches each opener with its closer", () => {
    expect(words("a (* IF (* nested *) END_IF *) b 'IF' // IF\nc").map((w) => w.word)).toEqual(["A", "B", "C"]);
    const found = blocks(SOURCE).map((b) => b.opener);
    expect(found).toEqual(["PROGRAM", "VAR", "IF", "CONFIGURATION", "RESOURCE"]);
  });

  it("folds each block between its opener's line and its closer's", () => {
    const lines = (pos: number) => SOURCE.slice(0, pos).split("\n").length;
    const folds = foldRanges(SOURCE).map((r) => [lines(r.from), lines(r.to)]);
    expect(folds).toEqual([
      [1, 9], // PROGRAM … END_PROGRAM: lines 2-9 hidden
      [2, 4], // VAR … END_VAR
      [6, 7], // IF … END_IF
      [11, 15], // CONFIGURATION (its PROGRAM Main WITH … opens nothing)
      [12, 14],
    ]);
  });
});

describe("completion and hover from the symbols", () => {
  it("offers an FB instance's inputs and outputs after a dot", () => {
    const text = `${SOURCE.slice(0, SOURCE.indexOf("t(IN"))}IF t.`;
    const c = complete(text, text.length, "main.st", SYMBOLS)!;
    expect(c.options.map((o) => o.label)).toEqual(["IN", "PT", "Q", "ET"]);
    expect(c.options[1].detail).toBe("TIME (VAR_INPUT)");
  });

  it("offers the parameters inside a call, the POU's variables, FBs, functions and keywords", () => {
    const text = `${SOURCE.slice(0, SOURCE.indexOf("t(IN"))}t(IN := TRUE, P`;
    const c = complete(text, text.length, "main.st", SYMBOLS)!;
    const labels = c.options.map((o) => o.label);
    expect(c.from).toBe(text.length - 1);
    expect(labels.slice(0, 4)).toEqual(["IN :=", "PT :=", "Q =>", "ET =>"]);
    expect(c.options[1].apply).toBe("PT := ");
    expect(labels).toContain("count");
    expect(labels).toContain("TON");
    expect(labels).toContain("LIMIT");
    expect(labels).toContain("END_IF");
    expect(c.options.find((o) => o.label === "count")!.detail).toBe("DINT — Main.count");
  });

  it("offers nothing in a comment", () => {
    const text = "PROGRAM P (* cou";
    expect(complete(text, text.length, "main.st", SYMBOLS)).toBeNull();
  });

  it("says a variable's type and shared variable, an FB's and a function's signature", () => {
    expect(hoverText("COUNT", "main.st", 7, SYMBOLS)).toBe("count : DINT (VAR) — shared variable Main.count");
    expect(hoverText("TON", "main.st", 7, SYMBOLS)).toBe("FUNCTION_BLOCK TON(IN: BOOL, PT: TIME) => Q: BOOL, ET: TIME");
    expect(hoverText("limit", "main.st", 7, SYMBOLS)).toBe(
      "FUNCTION LIMIT(MN: ANY_ELEMENTARY, IN: ANY_ELEMENTARY, MX: ANY_ELEMENTARY) : T",
    );
    expect(hoverText("nothing", "main.st", 7, SYMBOLS)).toBeNull();
  });
});

describe("the check's errors", () => {
  it("become ranges of the file from the column to the end of the word, other files left out", () => {
    const text = "PROGRAM P\nVAR x : DINT; END_VAR\nx := flag;\nEND_PROGRAM\n";
    const d = diagnostics(
      [
        { file: "main.st", line: 3, column: 6, code: "undeclared", message: "no variable 'flag'" },
        { file: "config.st", line: 1, column: 1, code: "type", message: "elsewhere" },
        { file: "main.st", line: 99, column: 99, code: "syntax", message: "past the end" },
      ],
      "main.st",
      text,
    );
    expect(d.map((x) => text.slice(x.from, x.to))).toEqual(["flag", ""]);
    expect(d[0]).toMatchObject({ severity: "error", message: "no variable 'flag'", source: "undeclared" });
    expect(d[1].from).toBe(text.length);
  });

  it("print as stc prints them, and a diff's lines by kind", () => {
    const listed = problemList({
      errors: [],
      problems: [{ file: "main.st", line: 8, column: 8, code: "type", message: "m" }],
    });
    expect(listed.textContent).toBe("main.st:8:8: error[type]: m");
    expect(diffLines("--- a/m.st\n+++ b/m.st\n@@ -1 +1 @@\n-x\n+y\n z\n").map((l) => l.kind)).toEqual([
      "file",
      "file",
      "hunk",
      "removed",
      "added",
      "same",
    ]);
  });
});
