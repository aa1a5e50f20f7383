// monitor-values.test.ts -- how the ST editor's monitor and the Watch page show a value (TRUE/FALSE with
// their own classes, integers as they are, reals short, a forced value marked) and how the editor's
// popover reads a typed value (a BOOL's words, a number, anything else refused with what to type).
import { describe, expect, it } from "vitest";
import { parseTyped } from "../../src/programs/value_popover";
import { valueClass, valueText } from "../../src/programs/values";

describe("monitored values", () => {
  it("shows BOOLs as TRUE/FALSE, each with its own class, and marks a forced value", () => {
    expect(valueText(true)).toBe("TRUE");
    expect(valueText(false)).toBe("FALSE");
    expect(valueClass(true)).toContain("st-mon-true");
    expect(valueClass(false)).toContain("st-mon-false");
    expect(valueClass(3, true)).toBe("st-mon st-mon-num st-mon-forced");
  });

  it("shows integers whole, reals to six significant digits, and an unread value as ?", () => {
    expect(valueText(1010)).toBe("1010");
    expect(valueText(Math.fround(0.4196))).toBe("0.4196"); // a REAL as the segment holds it
    expect(valueText(null)).toBe("?");
  });

  it("reads what is typed by the variable's current value", () => {
    expect(parseTyped("TRUE", false)).toEqual({ value: true });
    expect(parseTyped("0", true)).toEqual({ value: false });
    expect(parseTyped("yes", true)).toEqual({ error: 'a BOOL takes TRUE, FALSE, 1 or 0, not "yes"' });
    expect(parseTyped(" 2.5 ", 1)).toEqual({ value: 2.5 });
    expect(parseTyped("two", 1)).toEqual({ error: 'type a number, not "two"' });
  });
});
