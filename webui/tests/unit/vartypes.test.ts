// vartypes.test.ts -- client-side checks of a value typed for a variable, by its C type.
import { describe, expect, it } from "vitest";
import { formatValue, intRange, kindOf, parseValue } from "../../src/plot/vartypes";

const ok = (text: string, type: string, size: number) => {
  const r = parseValue(text, type, size);
  if (!r.ok) throw new Error(r.error);
  return r.value;
};
const refused = (text: string, type: string, size: number) => {
  const r = parseValue(text, type, size);
  expect(r.ok).toBe(false);
  return r.ok ? "" : r.error;
};

describe("kindOf", () => {
  it("knows the layout's type names", () => {
    for (const t of ["short", "int", "int32_t", "int8_t", "long long", "signed char", "int64_t"])
      expect(kindOf(t)).toBe("signed");
    for (const t of [
      "unsigned short",
      "uint32_t",
      "uint16_t",
      "uint8_t",
      "unsigned",
      "unsigned char",
      "size_t",
      "uint64_t",
    ])
      expect(kindOf(t)).toBe("unsigned");
    for (const t of ["double", "float"]) expect(kindOf(t)).toBe("float");
    expect(kindOf("bool")).toBe("bool");
    expect(kindOf("char")).toBe("char");
    expect(kindOf("struct pose")).toBeNull();
  });

  it("has the integer ranges of C", () => {
    expect(intRange(true, 2)).toEqual([-32768n, 32767n]);
    expect(intRange(false, 4)).toEqual([0n, 4294967295n]);
    expect(intRange(true, 8)).toEqual([-(2n ** 63n), 2n ** 63n - 1n]);
  });
});

describe("parseValue", () => {
  it("takes integers within the range of the type's size and signedness", () => {
    expect(ok("-32768", "short", 2)).toBe(-32768);
    expect(ok("32767", "short", 2)).toBe(32767);
    expect(refused("32768", "short", 2)).toContain("-32768..32767");
    expect(ok("65535", "unsigned short", 2)).toBe(65535);
    expect(refused("-1", "uint16_t", 2)).toContain("out of the range");
    expect(ok("2147483647", "int32_t", 4)).toBe(2147483647);
    expect(refused("2147483648", "int32_t", 4)).toContain("out of the range");
    expect(ok("4294967295", "uint32_t", 4)).toBe(4294967295);
    expect(refused("4294967296", "uint32_t", 4)).toContain("out of the range");
    expect(ok("-128", "int8_t", 1)).toBe(-128);
    expect(refused("128", "int8_t", 1)).toContain("out of the range");
    expect(ok("0x7f", "int8_t", 1)).toBe(127);
    expect(ok(" +12 ", "int", 4)).toBe(12);
  });

  it("refuses what is not an integer for an integer type", () => {
    expect(refused("1.5", "int32_t", 4)).toContain("integer");
    expect(refused("1e3", "short", 2)).toContain("integer");
    expect(refused("abc", "uint32_t", 4)).toContain("integer");
    expect(refused("", "short", 2)).toContain("type a value");
  });

  it("refuses 64-bit values the browser cannot send exactly", () => {
    expect(ok("9007199254740991", "int64_t", 8)).toBe(9007199254740991);
    expect(refused("9007199254740993", "int64_t", 8)).toContain("2^53");
  });

  it("takes finite numbers for floating types, a float's within its range", () => {
    expect(ok("1.5", "double", 8)).toBe(1.5);
    expect(ok("-2e-3", "double", 8)).toBe(-0.002);
    expect(ok(".5", "float", 4)).toBe(0.5);
    expect(ok("1e300", "double", 8)).toBe(1e300);
    expect(refused("1e300", "float", 4)).toContain("float");
    expect(refused("1e999", "double", 8)).toContain("finite");
    expect(refused("NaN", "double", 8)).toContain("number");
    expect(refused("0x10", "double", 8)).toContain("number");
  });

  it("takes true/false/1/0 for bool and sends a boolean", () => {
    expect(ok("true", "bool", 1)).toBe(true);
    expect(ok("0", "bool", 1)).toBe(false);
    expect(ok("FALSE", "bool", 1)).toBe(false);
    expect(refused("2", "bool", 1)).toContain("bool");
  });

  it("takes a small integer or a quoted ASCII character for char", () => {
    expect(ok("'A'", "char", 1)).toBe(65);
    expect(ok("-5", "char", 1)).toBe(-5);
    expect(refused("200", "char", 1)).toContain("out of the range");
    expect(refused("'é'", "char", 1)).toContain("ASCII");
  });

  it("leaves a type it does not know to irpd, within its size", () => {
    expect(ok("255", "BYTE", 1)).toBe(255);
    expect(ok("-1", "BYTE", 1)).toBe(-1);
    expect(refused("256", "BYTE", 1)).toContain("out of the range");
    expect(refused("1", "struct x", 24)).toContain("cannot be written");
  });
});

describe("formatValue", () => {
  it("shows numbers by kind", () => {
    expect(formatValue(2, "double")).toBe("2.0");
    expect(formatValue(0.123456789012, "double")).toBe("0.12345679");
    expect(formatValue(-7.144e-5, "double")).toBe("-7.1440e-5");
    expect(formatValue(42, "int32_t")).toBe("42");
    expect(formatValue(true, "bool")).toBe("true");
    expect(formatValue(null, "double")).toBe("—");
  });
});
