// st_symbols.ts -- completion and hover from the check's symbols (POST /programs/check), with no
// CodeMirror in it (pure, unit-tested): the variables of the POU the cursor is in, the globals, the
// POUs, FB types and functions; after `inst.` an FB instance's inputs and outputs; inside `inst(`
// or `FUNC(` the parameters as `IN := ` / `Q => `; the type of a word on hover.  Keywords and the
// standard names come from st_language.ts, generated from the grammar and the compiler's tables.
import type { components } from "../api/schema";
import { ST_FUNCTIONS, ST_KEYWORDS, ST_TYPES } from "./st_language";
import { lineStarts, skipAt } from "./st_text";

type S = components["schemas"];
export type Symbols = S["Symbols"];
export type SymbolPou = S["SymbolPou"];
export type SymbolVar = S["SymbolVar"];
export type SymbolParam = S["SymbolParam"];

export interface Option {
  label: string;
  /** variable, function, class (an FB type), keyword, type, property (a parameter) */
  type: string;
  detail?: string;
  /** the text inserted, when not the label */
  apply?: string;
}

export interface Completion {
  from: number;
  options: Option[];
}

/** The POU of `path` whose declaration starts last at or before the 1-based `line`. */
export function pouAt(symbols: Symbols | null, path: string, line: number): SymbolPou | null {
  let best: SymbolPou | null = null;
  for (const p of symbols?.pous ?? []) if (p.file === path && p.line <= line && (!best || p.line > best.line)) best = p;
  return best;
}

function lineOf(text: string, pos: number): number {
  const starts = lineStarts(text.slice(0, pos));
  return starts.length;
}

function findVar(symbols: Symbols | null, pou: SymbolPou | null, name: string): { type: string | null } | null {
  const u = name.toUpperCase();
  const local = pou?.vars.find((v) => v.name.toUpperCase() === u);
  if (local) return local;
  return symbols?.globals.find((g) => g.name.toUpperCase() === u) ?? null;
}

function fbType(symbols: Symbols | null, type: string | null | undefined) {
  if (!type) return null;
  const u = type.toUpperCase();
  return symbols?.fb_types.find((f) => f.name.toUpperCase() === u) ?? null;
}

function functionNamed(symbols: Symbols | null, name: string) {
  const u = name.toUpperCase();
  return symbols?.functions.find((f) => f.name.toUpperCase() === u) ?? ST_FUNCTIONS.find((f) => f.name === u) ?? null;
}

function paramText(p: { name: string; type: string | null }): string {
  return `${p.name}: ${p.type ?? "?"}`;
}

/** `TON(IN: BOOL, PT: TIME) => Q: BOOL, ET: TIME` */
export function signature(
  name: string,
  params: readonly (SymbolParam | { name: string; type: string; kind?: string })[],
  result?: string | null,
): string {
  const ins = params.filter((p) => p.kind !== "VAR_OUTPUT").map(paramText);
  const outs = params.filter((p) => p.kind === "VAR_OUTPUT").map(paramText);
  return `${name}(${ins.join(", ")})${result ? ` : ${result}` : ""}${outs.length ? ` => ${outs.join(", ")}` : ""}`;
}

/** The unclosed call the position is in (`t1(IN := x, |`): the callee's name, or null. */
export function callAt(text: string, pos: number): string | null {
  let depth = 0;
  const lineStart = Math.max(0, text.lastIndexOf(";", pos - 1) + 1);
  for (let i = pos - 1; i >= lineStart; i--) {
    const c = text[i];
    if (c === ")") depth++;
    else if (c === "(") {
      if (depth === 0) {
        const m = /([A-Za-z_][A-Za-z0-9_]*)\s*$/.exec(text.slice(lineStart, i));
        return m ? m[1] : null;
      }
      depth--;
    }
  }
  return null;
}

const CLOSERS: Record<string, string> = { "(*": "*)", "/*": "*/", "{": "}", "'": "'", '"': '"' };

/** Whether a comment, pragma or string as skipAt() spans it is closed (a // comment never is before its line ends). */
function closed(s: string): boolean {
  const open = s.startsWith("(*") || s.startsWith("/*") || s.startsWith("//") ? s.slice(0, 2) : s[0];
  const close = CLOSERS[open];
  return close !== undefined && s.length >= open.length + close.length && s.endsWith(close);
}

function insideCommentOrString(text: string, pos: number): boolean {
  let i = 0;
  while (i < pos) {
    const end = skipAt(text, i);
    if (end >= 0) {
      if (end > pos || (end === pos && !closed(text.slice(i, end)))) return true;
      i = end;
    } else i++;
  }
  return false;
}

/** What may be typed at `pos` of the file `path`. */
export function complete(text: string, pos: number, path: string, symbols: Symbols | null): Completion | null {
  if (insideCommentOrString(text, pos)) return null;
  const before = text.slice(Math.max(0, pos - 200), pos);
  const word = /[A-Za-z_][A-Za-z0-9_]*$/.exec(before)?.[0] ?? "";
  const from = pos - word.length;
  const pou = pouAt(symbols, path, lineOf(text, pos));
  // after `inst.`: the instance's inputs and outputs (its FB type's parameters)
  const member = /([A-Za-z_][A-Za-z0-9_]*)\.[A-Za-z0-9_]*$/.exec(before);
  if (member) {
    const fb = fbType(symbols, findVar(symbols, pou, member[1])?.type);
    if (!fb) return null;
    return {
      from,
      options: fb.params
        .filter((p) => p.kind !== "VAR_IN_OUT")
        .map((p) => ({ label: p.name, type: "property", detail: `${p.type ?? "?"} (${p.kind})` })),
    };
  }
  const options: Option[] = [];
  const callee = callAt(text, from);
  if (callee) {
    const fb = fbType(symbols, findVar(symbols, pou, callee)?.type);
    const params = fb?.params ?? functionNamed(symbols, callee)?.params ?? [];
    for (const p of params) {
      const out = "kind" in p && p.kind === "VAR_OUTPUT";
      options.push({
        label: `${p.name} ${out ? "=>" : ":="}`,
        apply: `${p.name} ${out ? "=>" : ":="} `,
        type: "property",
        detail: p.type ?? "",
      });
    }
  }
  for (const v of pou?.vars ?? [])
    options.push({
      label: v.name,
      type: "variable",
      detail: `${v.type ?? "?"}${v.paths.length ? ` — ${v.paths[0]}` : ""}`,
    });
  for (const g of symbols?.globals ?? []) options.push({ label: g.name, type: "variable", detail: g.type ?? "" });
  for (const f of symbols?.fb_types ?? []) options.push({ label: f.name, type: "class", detail: "FUNCTION_BLOCK" });
  for (const f of symbols?.functions ?? ST_FUNCTIONS)
    options.push({ label: f.name, type: "function", detail: signature("", f.params, f.result) });
  for (const k of ST_KEYWORDS) options.push({ label: k, type: "keyword" });
  for (const t of ST_TYPES) options.push({ label: t, type: "type" });
  return { from, options };
}

/** What hovering `word` at 1-based `line` of `path` says: a variable's type and shared variable, an FB
 * type's or a function's signature. */
export function hoverText(word: string, path: string, line: number, symbols: Symbols | null): string | null {
  const pou = pouAt(symbols, path, line);
  const u = word.toUpperCase();
  const local = pou?.vars.find((v) => v.name.toUpperCase() === u);
  if (local)
    return `${local.name} : ${local.type ?? "?"} (${local.kind}${local.constant ? " CONSTANT" : ""})${
      local.paths.length ? ` — shared variable ${local.paths.join(", ")}` : ""
    }`;
  const g = symbols?.globals.find((x) => x.name.toUpperCase() === u);
  if (g) return `${g.name} : ${g.type ?? "?"} (VAR_GLOBAL)${g.paths.length ? ` — shared variable ${g.paths[0]}` : ""}`;
  const fb = symbols?.fb_types.find((f) => f.name.toUpperCase() === u);
  if (fb) return `FUNCTION_BLOCK ${signature(fb.name, fb.params)}`;
  const f = functionNamed(symbols, word);
  if (f) return `FUNCTION ${signature(f.name, f.params, f.result)}`;
  const p = symbols?.pous.find((x) => x.name.toUpperCase() === u);
  if (p) return `${p.kind} ${p.name} (${p.file}:${p.line})`;
  return null;
}
