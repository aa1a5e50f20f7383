// st_text.ts -- Structured Text as the editor reads it, with no CodeMirror in it (pure, unit-tested):
// the words of a source outside comments, strings and pragmas; the blocks that fold (each END_x
// keyword of the grammar closes its x: IF…END_IF, FUNCTION_BLOCK…END_FUNCTION_BLOCK, VAR_INPUT…
// END_VAR, …); errors of the check as ranges of the text.  The keywords come from st_language.ts,
// generated from st/st.lark (st/generate_editor.py).
import { ST_KEYWORDS } from "./st_language";

export interface Word {
  /** upper-case */
  word: string;
  from: number;
  to: number;
}

/** Where a comment, string or pragma starting at `i` ends (exclusive), or -1 when none starts there.
 * (* *) nests, as CODESYS and stc read it. */
export function skipAt(text: string, i: number): number {
  const c = text[i];
  const n = text[i + 1];
  if (c === "(" && n === "*") {
    let depth = 0;
    let j = i;
    while (j < text.length) {
      if (text[j] === "(" && text[j + 1] === "*") {
        depth++;
        j += 2;
      } else if (text[j] === "*" && text[j + 1] === ")") {
        depth--;
        j += 2;
        if (depth === 0) return j;
      } else j++;
    }
    return text.length;
  }
  if (c === "/" && n === "*") {
    const e = text.indexOf("*/", i + 2);
    return e < 0 ? text.length : e + 2;
  }
  if (c === "/" && n === "/") {
    const e = text.indexOf("\n", i);
    return e < 0 ? text.length : e;
  }
  if (c === "{") {
    const e = text.indexOf("}", i);
    return e < 0 ? text.length : e + 1;
  }
  if (c === "'" || c === '"') {
    let j = i + 1;
    while (j < text.length && text[j] !== c && text[j] !== "\n") j += text[j] === "$" ? 2 : 1;
    return Math.min(j + 1, text.length);
  }
  return -1;
}

/** The identifiers and keywords of `text` outside comments, strings and pragmas. */
export function words(text: string): Word[] {
  const out: Word[] = [];
  let i = 0;
  while (i < text.length) {
    const skipped = skipAt(text, i);
    if (skipped >= 0) {
      i = skipped;
      continue;
    }
    const c = text.charCodeAt(i);
    const isStart = (c >= 65 && c <= 90) || (c >= 97 && c <= 122) || c === 95;
    if (isStart) {
      let j = i + 1;
      while (j < text.length && /[A-Za-z0-9_]/.test(text[j])) j++;
      // a typed literal's prefix (T#1s, INT#5) and a member after '.' are not block words
      if (text[j] !== "#" && text[i - 1] !== ".") out.push({ word: text.slice(i, j).toUpperCase(), from: i, to: j });
      i = j;
    } else if (c >= 48 && c <= 57) {
      let j = i + 1;
      while (j < text.length && /[A-Za-z0-9_#.]/.test(text[j])) j++;
      i = j;
    } else i++;
  }
  return out;
}

/** opener -> its closer, from the grammar's END_ keywords (VAR, VAR_INPUT, VAR_GLOBAL, … close with END_VAR) */
export const BLOCKS: ReadonlyMap<string, string> = (() => {
  const m = new Map<string, string>();
  for (const k of ST_KEYWORDS) {
    if (!k.startsWith("END_")) continue;
    const opener = k.slice(4);
    if (opener === "VAR") {
      for (const v of ST_KEYWORDS) if (v === "VAR" || v.startsWith("VAR_")) m.set(v, k);
    } else if (ST_KEYWORDS.includes(opener)) m.set(opener, k);
  }
  return m;
})();

export interface Block {
  opener: string;
  /** the opening keyword's start and the closing keyword's end */
  from: number;
  to: number;
  /** the closing keyword's start */
  closeFrom: number;
}

/** The blocks of `text`: each opener matched with its closer (an unclosed one is left out). In a
 * CONFIGURATION, `PROGRAM inst WITH task : Type;` opens nothing. */
export function blocks(text: string): Block[] {
  const out: Block[] = [];
  const stack: Word[] = [];
  const closers = new Set(BLOCKS.values());
  for (const w of words(text)) {
    const top = stack[stack.length - 1]?.word;
    if (w.word === "PROGRAM" && (top === "CONFIGURATION" || top === "RESOURCE")) continue;
    if (BLOCKS.has(w.word)) stack.push(w);
    else if (closers.has(w.word)) {
      // the nearest opener this keyword closes; openers left open inside it are dropped
      for (let i = stack.length - 1; i >= 0; i--) {
        if (BLOCKS.get(stack[i].word) === w.word) {
          out.push({ opener: stack[i].word, from: stack[i].from, to: w.to, closeFrom: w.from });
          stack.length = i;
          break;
        }
      }
    }
  }
  return out.sort((a, b) => a.from - b.from);
}

/** Offsets of the line starts of `text`. */
export function lineStarts(text: string): number[] {
  const starts = [0];
  for (let i = 0; i < text.length; i++) if (text[i] === "\n") starts.push(i + 1);
  return starts;
}

/** The fold of each block that spans lines: from the end of the opener's line to the end of the
 * line before its closer (what stays visible: the opener's line and the closer's). */
export function foldRanges(text: string): { from: number; to: number }[] {
  const starts = lineStarts(text);
  const lineOf = (pos: number) => {
    let lo = 0;
    let hi = starts.length - 1;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (starts[mid] <= pos) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  };
  const out: { from: number; to: number }[] = [];
  for (const b of blocks(text)) {
    const open = lineOf(b.from);
    const close = lineOf(b.closeFrom);
    if (close <= open) continue;
    const openEnd = (starts[open + 1] ?? text.length + 1) - 1;
    const beforeClose = starts[close] - 1;
    if (beforeClose > openEnd) out.push({ from: openEnd, to: beforeClose });
  }
  return out;
}

export interface CheckError {
  file: string;
  line: number;
  column: number;
  code: string;
  message: string;
}

export interface Diagnostic {
  from: number;
  to: number;
  severity: "error";
  message: string;
  source: string;
}

/** The check's errors in `path` as ranges of `text`: from the error's column to the end of the word
 * or token there (at least one character, within the line). */
export function diagnostics(errors: readonly CheckError[], path: string, text: string): Diagnostic[] {
  const starts = lineStarts(text);
  const out: Diagnostic[] = [];
  for (const e of errors) {
    if (e.file !== path) continue;
    const li = Math.min(Math.max(e.line, 1), starts.length) - 1;
    const lineStart = starts[li];
    const lineEnd = li + 1 < starts.length ? starts[li + 1] - 1 : text.length;
    const from = Math.min(lineStart + Math.max(e.column, 1) - 1, lineEnd);
    let to = from;
    while (to < lineEnd && /[A-Za-z0-9_#.]/.test(text[to])) to++;
    if (to === from) to = Math.min(from + 1, lineEnd);
    out.push({ from, to: Math.max(to, from), severity: "error", message: e.message, source: e.code });
  }
  return out;
}
