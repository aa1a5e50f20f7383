// vartypes.ts -- what a value typed into the UI may be for a variable of a given C type, checked
// before it is sent (irpd checks again: this only saves a round trip and says why early).
export type Kind = "float" | "signed" | "unsigned" | "bool" | "char";

export interface Scalar {
  kind: Kind;
  size: number;
}

/** The kind of a layout type name, or null when the name says nothing we know. */
export function kindOf(type: string): Kind | null {
  const t = type.trim().replace(/\s+/g, " ");
  if (/^(float|double|long double|float\d+_t)$/.test(t)) return "float";
  if (/^(bool|_Bool)$/.test(t)) return "bool";
  if (t === "char") return "char";
  if (/^unsigned\b/.test(t) || /^u_?int(_least|_fast)?\d+_t$/.test(t) || /^(size_t|uintptr_t|uintmax_t)$/.test(t))
    return "unsigned";
  if (
    /^(signed\b.*|short( int)?|int|long( int)?|long long( int)?|int(_least|_fast)?\d+_t|ssize_t|intptr_t|intmax_t|ptrdiff_t)$/.test(
      t,
    )
  )
    return "signed";
  return null;
}

export function scalarOf(type: string, size: number): Scalar | null {
  const kind = kindOf(type);
  return kind ? { kind, size } : null;
}

/** The integer range of `size` bytes, signed or not. */
export function intRange(signed: boolean, size: number): [bigint, bigint] {
  const bits = BigInt(8 * size);
  return signed ? [-(1n << (bits - 1n)), (1n << (bits - 1n)) - 1n] : [0n, (1n << bits) - 1n];
}

const FLOAT_MAX = 3.4028234663852886e38;
const SAFE = BigInt(Number.MAX_SAFE_INTEGER);

export type Parsed = { ok: true; value: number | boolean } | { ok: false; error: string };

function integer(text: string, lo: bigint, hi: bigint, type: string): Parsed {
  const m = /^([+-]?)(0x[0-9a-f]+|\d+)$/i.exec(text);
  if (!m) return { ok: false, error: `${type} takes an integer, not "${text}"` };
  let v = BigInt(m[2]);
  if (m[1] === "-") v = -v;
  if (v < lo || v > hi) return { ok: false, error: `${text} is out of the range of ${type}: ${lo}..${hi}` };
  if (v > SAFE || v < -SAFE)
    return { ok: false, error: `${text} is beyond ±2^53 and cannot be sent exactly from the browser` };
  return { ok: true, value: Number(v) };
}

/** Checks `text` against the variable's type; gives the JSON value to send or the reason not to. */
export function parseValue(text: string, type: string, size: number): Parsed {
  const s = text.trim();
  if (!s) return { ok: false, error: "type a value" };
  const kind = kindOf(type);
  switch (kind) {
    case "bool": {
      const l = s.toLowerCase();
      if (l === "true" || l === "1") return { ok: true, value: true };
      if (l === "false" || l === "0") return { ok: true, value: false };
      return { ok: false, error: `bool takes true, false, 1 or 0, not "${s}"` };
    }
    case "float": {
      if (!/^[+-]?(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$/i.test(s))
        return { ok: false, error: `${type} takes a number, not "${s}"` };
      const v = Number(s);
      if (!Number.isFinite(v)) return { ok: false, error: `${s} is not a finite ${type}` };
      if (size === 4 && Math.abs(v) > FLOAT_MAX)
        return { ok: false, error: `${s} is beyond the range of a float (±3.4e38)` };
      if (size !== 4 && size !== 8) return { ok: false, error: `a ${size}-byte ${type} cannot be written` };
      return { ok: true, value: v };
    }
    case "char": {
      const q = /^'(.)'$/u.exec(s);
      if (q) {
        const code = q[1].codePointAt(0)!;
        if (code > 127) return { ok: false, error: `'${q[1]}' is not an ASCII character` };
        return { ok: true, value: code };
      }
      const [lo, hi] = intRange(true, size || 1);
      return integer(s, lo, hi, type);
    }
    case "signed":
    case "unsigned": {
      if (![1, 2, 4, 8].includes(size)) return { ok: false, error: `a ${size}-byte ${type} cannot be written` };
      const [lo, hi] = intRange(kind === "signed", size);
      return integer(s, lo, hi, type);
    }
    default: {
      // A type we do not know by name: an integer that fits its size either way; irpd decides.
      if (![1, 2, 4, 8].includes(size))
        return { ok: false, error: `${type} (${size} bytes) cannot be written from here` };
      return integer(s, intRange(true, size)[0], intRange(false, size)[1], type);
    }
  }
}

/** How a value read from the agent is shown. */
export function formatValue(v: unknown, type: string): string {
  if (typeof v === "boolean") return v ? "true" : "false";
  if (typeof v !== "number") return v === null || v === undefined ? "—" : String(v);
  if (kindOf(type) === "float") {
    if (Number.isInteger(v) && Math.abs(v) < 1e15) return v.toFixed(1);
    const a = Math.abs(v);
    return a < 1e-4 || a >= 1e9 ? v.toExponential(4) : String(Number(v.toPrecision(8)));
  }
  return String(v);
}
