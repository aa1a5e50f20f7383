// place.ts -- where an error is, as the agent answers it: the fields irpd gives (file, line, column,
// module, field; protocol/control.json #/shapes/place), never found in the message's text.

/** Where an error is, as the agent gives it: the fields that are known (irpd's place, protocol/control.json). */
export interface Place {
  file?: string | null;
  line?: number | null;
  column?: number | null;
  module?: string | null;
  field?: string | null;
}

/** The known fields of a place in a body ({file?, line?, column?, module?, field?}). */
export function placeIn(body: unknown): Place {
  const b = body && typeof body === "object" ? (body as Record<string, unknown>) : {};
  const num = (v: unknown) => (typeof v === "number" && Number.isFinite(v) ? v : undefined);
  const str = (v: unknown) => (typeof v === "string" && v ? v : undefined);
  return { file: str(b.file), line: num(b.line), column: num(b.column), module: str(b.module), field: str(b.field) };
}

/**
 * "module.xml:12:5 (module cntr1, <period>)" from a place's fields: the file with its line and
 * column, then the module and the module.xml field when known; "" when none is.
 */
export function placeText(p: Place): string {
  const file = p.file
    ? p.file + (p.line ? `:${p.line}` : "") + (p.line && p.column ? `:${p.column}` : "")
    : p.line
      ? `line ${p.line}`
      : "";
  const about = [p.module ? `module ${p.module}` : "", p.field ? `<${p.field}>` : ""].filter(Boolean).join(", ");
  if (!about) return file;
  return file ? `${file} (${about})` : about;
}
