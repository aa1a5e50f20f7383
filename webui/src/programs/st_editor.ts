// st_editor.ts -- the Structured Text editor on CodeMirror 6: highlighting by a stream tokenizer whose
// keywords, types and standard names come from st_language.ts (generated from the grammar), folding
// of the grammar's blocks (st_text.ts), bracket matching and the rest of basicSetup, completion and
// hover from the check's symbols (st_symbols.ts), and the check's errors as lint diagnostics, the
// check sent ~300 ms after the last key.  Read-only for those who may not edit.
import { autocompletion } from "@codemirror/autocomplete";
import { foldService, StreamLanguage, type StringStream } from "@codemirror/language";
import { type Diagnostic, linter, lintGutter } from "@codemirror/lint";
import { EditorState, type Extension } from "@codemirror/state";
import { EditorView, hoverTooltip } from "@codemirror/view";
import { basicSetup } from "codemirror";
import type { components } from "../api/schema";
import { ST_FUNCTIONS, ST_KEYWORDS, ST_LIBRARY, ST_TYPES } from "./st_language";
import { complete, hoverText, type Symbols } from "./st_symbols";
import { diagnostics, foldRanges } from "./st_text";

export type CheckResult = components["schemas"]["CheckResult"];
export const CHECK_DELAY_MS = 300;

const KEYWORDS = new Set(ST_KEYWORDS);
const TYPES = new Set(ST_TYPES);
const STANDARD = new Set([...ST_FUNCTIONS.map((f) => f.name), ...ST_LIBRARY.map((p) => p.name.toUpperCase())]);

interface TokState {
  /** depth of (* *) comments open at the line's start; -1: inside a slash-star comment */
  comment: number;
}

function inComment(stream: StringStream, state: TokState): string {
  while (!stream.eol()) {
    if (state.comment < 0) {
      if (stream.match("*/")) {
        state.comment = 0;
        break;
      }
      stream.next();
    } else if (stream.match("(*")) state.comment++;
    else if (stream.match("*)")) {
      state.comment--;
      if (state.comment === 0) break;
    } else stream.next();
  }
  return "comment";
}

export const stLanguage = StreamLanguage.define<TokState>({
  name: "st",
  startState: () => ({ comment: 0 }),
  token(stream, state) {
    if (state.comment !== 0) return inComment(stream, state);
    if (stream.eatSpace()) return null;
    if (stream.match("(*")) {
      state.comment = 1;
      return inComment(stream, state);
    }
    if (stream.match("/*")) {
      state.comment = -1;
      return inComment(stream, state);
    }
    if (stream.match("//")) {
      stream.skipToEnd();
      return "comment";
    }
    if (stream.match(/^\{[^}]*\}?/)) return "meta";
    if (stream.match(/^'(\$.|[^'$])*'?/) || stream.match(/^"(\$.|[^"$])*"?/)) return "string";
    if (stream.match(/^[A-Za-z_]+#[-+]?[0-9A-Za-z_.:-]+/)) return "number"; // T#1s, INT#5, DT#…, Color#Red
    if (stream.match(/^(2#[01_]+|8#[0-7_]+|16#[0-9A-Fa-f_]+|[0-9][0-9_]*(\.[0-9_]+)?([eE][-+]?[0-9]+)?)/))
      return "number";
    const w = stream.match(/^[A-Za-z_][A-Za-z0-9_]*/) as RegExpMatchArray | null;
    if (w) {
      const u = w[0].toUpperCase();
      if (u === "TRUE" || u === "FALSE") return "atom";
      if (KEYWORDS.has(u)) return "keyword";
      if (TYPES.has(u)) return "type";
      if (STANDARD.has(u)) return "builtin";
      return "variable";
    }
    if (stream.match(/^(:=|=>|<>|<=|>=|\*\*|[-+*/=<>&])/)) return "operator";
    stream.next();
    return null;
  },
  languageData: { commentTokens: { line: "//", block: { open: "(*", close: "*)" } } },
});

/** Folding from the grammar's blocks, recomputed once per document. */
const stFolding = (() => {
  let doc: unknown = null;
  let ranges: { from: number; to: number }[] = [];
  return foldService.of((state, lineStart, lineEnd) => {
    if (state.doc !== doc) {
      doc = state.doc;
      ranges = foldRanges(state.doc.toString());
    }
    return ranges.find((r) => r.from >= lineStart && r.from <= lineEnd) ?? null;
  });
})();

const THEME = EditorView.theme({
  "&": { minHeight: "24rem", maxHeight: "70vh", border: "1px solid #c8ccd2", fontSize: "13px", background: "#fff" },
  ".cm-scroller": { fontFamily: "ui-monospace, monospace", overflow: "auto" },
  ".st-hover": { padding: "0.25rem 0.5rem", fontFamily: "ui-monospace, monospace", fontSize: "12px" },
});

export interface StEditorOptions {
  parent: HTMLElement;
  path: string;
  text: string;
  readOnly: boolean;
  /** checks the text in its set (POST /programs/check) */
  check: (text: string) => Promise<CheckResult>;
  /** after each check: its answer, or what went wrong */
  onChecked: (result: CheckResult | null, error?: unknown) => void;
  /** the document changed (by the user) */
  onChange?: (text: string) => void;
  /** more extensions (the monitor's decorations, st_monitor.ts) */
  extensions?: Extension[];
}

export class StEditor {
  readonly view: EditorView;
  symbols: Symbols | null = null;

  constructor(opts: StEditorOptions) {
    const lint = linter(
      async (view): Promise<Diagnostic[]> => {
        const text = view.state.doc.toString();
        try {
          const r = await opts.check(text);
          this.symbols = r.symbols;
          opts.onChecked(r);
          return diagnostics(r.errors, opts.path, text);
        } catch (e) {
          opts.onChecked(null, e);
          return [];
        }
      },
      { delay: CHECK_DELAY_MS },
    );
    const hover = hoverTooltip((view, pos) => {
      const word = view.state.wordAt(pos);
      if (!word) return null;
      const line = view.state.doc.lineAt(pos).number;
      const text = hoverText(view.state.sliceDoc(word.from, word.to), opts.path, line, this.symbols);
      if (!text) return null;
      return {
        pos: word.from,
        end: word.to,
        create: () => {
          const dom = document.createElement("div");
          dom.className = "st-hover";
          dom.dataset.testid = "st-hover";
          dom.textContent = text;
          return { dom };
        },
      };
    });
    // in a shadow root of its own: CodeMirror's styles are then a constructed style sheet, which the
    // UI's Content-Security-Policy (style-src 'self', api/headers.py) lets in, as it would not a <style>
    const host = document.createElement("div");
    host.className = "st-editor-host";
    opts.parent.replaceChildren(host);
    const root = host.attachShadow({ mode: "open" });
    this.view = new EditorView({
      parent: root,
      root,
      state: EditorState.create({
        doc: opts.text,
        extensions: [
          basicSetup,
          THEME,
          stLanguage,
          stFolding,
          autocompletion({
            override: [
              (ctx) => {
                const c = complete(ctx.state.doc.toString(), ctx.pos, opts.path, this.symbols);
                if (
                  !c ||
                  (c.from === ctx.pos && !ctx.explicit && !/[.(,]\s*$/.test(ctx.state.sliceDoc(ctx.pos - 2, ctx.pos)))
                )
                  return null;
                return { from: c.from, options: c.options, validFor: /^[A-Za-z0-9_]*$/ };
              },
            ],
          }),
          lint,
          lintGutter(),
          hover,
          EditorState.readOnly.of(opts.readOnly),
          EditorView.editable.of(!opts.readOnly),
          EditorView.updateListener.of((u) => {
            if (u.docChanged) opts.onChange?.(u.state.doc.toString());
          }),
          ...(opts.extensions ?? []),
        ],
      }),
    });
  }

  text(): string {
    return this.view.state.doc.toString();
  }

  /** Scrolls to a 1-based line and puts the cursor there. */
  goTo(line: number): void {
    const l = this.view.state.doc.line(Math.min(Math.max(line, 1), this.view.state.doc.lines));
    this.view.dispatch({ selection: { anchor: l.from }, effects: EditorView.scrollIntoView(l.from, { y: "start" }) });
    this.view.focus();
  }

  destroy(): void {
    this.view.destroy();
  }
}
