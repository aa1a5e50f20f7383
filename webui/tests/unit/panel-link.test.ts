// panel-link.test.ts -- plot panels named in the page address (#/variables?plot=...).
import { describe, expect, it } from "vitest";
import { panelsFromHash } from "../../src/plot/panel-link";

describe("panelsFromHash", () => {
  it("reads panels split by ';' and paths by ','", () => {
    const p = panelsFromHash("#/variables?plot=" + encodeURIComponent("a.b[0],a.c;SIG.wave[3]"));
    expect(p?.map((c) => c.paths)).toEqual([["a.b[0]", "a.c"], ["SIG.wave[3]"]]);
    expect(p?.[0].mode).toBe("time");
  });
  it("is null without a plot parameter", () => {
    expect(panelsFromHash("#/variables")).toBeNull();
    expect(panelsFromHash("#/variables?x=1")).toBeNull();
  });
});
