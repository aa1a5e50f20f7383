// st_monitor.ts -- Monitor in the ST editor (docs/programming.md "Monitoring"): every variable of the
// visible lines gets its running value beside it (a CodeMirror widget decoration; BOOLs coloured TRUE
// / FALSE, a forced value marked), an FB instance or a struct a widget that expands to its fields, and
// each IF/ELSIF/WHILE/UNTIL condition and CASE selector its value, evaluated by the agent with the ST
// compiler's own folding (POST /programs/monitor: one request per refresh for the visible lines, one
// read of the shared memory).  Refreshed every MONITOR_MS, start to start, never two requests at once.
import { type Extension, StateEffect, StateField } from "@codemirror/state";
import { Decoration, type DecorationSet, EditorView, WidgetType } from "@codemirror/view";
import type { components } from "../api/schema";
import { poll } from "../ops/dom";
import { MONITOR_MS, type Value, valueClass, valueText } from "./values";

export type MonitorAnswer = components["schemas"]["MonitorAnswer"];
type Occurrence = components["schemas"]["Occurrence"];
type Condition = components["schemas"]["Condition"];
type Leaf = components["schemas"]["LeafValue"];
/** What a click on a value (or a field of an expanded instance) opens: the page's popover. */
export type OnValue = (target: HTMLElement, leaf: { path: string; type: string | null; value: Value }) => void;

class ValueWidget extends WidgetType {
  constructor(
    readonly o: Occurrence,
    readonly fields: Leaf[] | undefined,
    readonly onValue: OnValue | null,
    readonly toggle: (path: string) => void,
  ) {
    super();
  }
  private key(): string {
    const f = (this.fields ?? []).map((l) => `${l.path}=${l.value}${l.forced ? "F" : ""}`).join(",");
    return `${this.o.path}|${this.o.value}|${this.o.forced}|${this.o.group}|${f}`;
  }
  eq(other: ValueWidget): boolean {
    return other.key() === this.key();
  }
  toDOM(): HTMLElement {
    const span = document.createElement("span");
    span.dataset.path = this.o.path;
    span.dataset.testid = "st-mon-value";
    if (this.o.group) {
      span.className = "st-mon st-mon-group";
      const button = document.createElement("button");
      button.className = "st-mon-expand";
      button.dataset.testid = "st-mon-expand";
      button.textContent = this.fields ? "▾" : "▸";
      button.title = `${this.o.path}: ${this.fields ? "hide" : "show"} its fields`;
      button.onmousedown = (e) => e.preventDefault();
      button.onclick = () => this.toggle(this.o.path);
      span.append(button);
      for (const l of this.fields ?? []) span.append(this.leaf(l.path, l.value, l.forced, l.type, true));
      return span;
    }
    return this.leaf(this.o.path, this.o.value, this.o.forced ?? false, this.o.type ?? null, false, span);
  }
  private leaf(path: string, v: Value, forced: boolean, type: string | null, field: boolean, into?: HTMLElement) {
    const span = into ?? document.createElement("span");
    span.className = valueClass(v, forced);
    span.dataset.path = path;
    if (field) span.dataset.testid = "st-mon-field";
    const name = field ? `${path.slice(path.lastIndexOf(".") + 1)}=` : "";
    span.textContent = `${name}${valueText(v)}${forced ? " F" : ""}`;
    span.title = `${path}${type ? ` : ${type}` : ""}${forced ? " (forced)" : ""}`;
    if (this.onValue) {
      const open = this.onValue;
      span.classList.add("st-mon-action");
      span.onmousedown = (e) => e.preventDefault();
      span.onclick = (e) => {
        e.stopPropagation();
        open(span, { path, type, value: v });
      };
    }
    return span;
  }
  ignoreEvent(): boolean {
    return true;
  }
}

class ConditionWidget extends WidgetType {
  constructor(readonly c: Condition) {
    super();
  }
  eq(other: ConditionWidget): boolean {
    return other.c.value === this.c.value && other.c.reason === this.c.reason;
  }
  toDOM(): HTMLElement {
    const span = document.createElement("span");
    span.dataset.testid = "st-mon-cond";
    span.dataset.line = String(this.c.line);
    const v = this.c.value;
    span.className = `${valueClass(v)} st-mon-cond${v === null || v === undefined ? " st-mon-none" : ""}`;
    span.textContent = v === null || v === undefined ? "—" : valueText(v);
    span.title = v === null || v === undefined ? `${this.c.what}: not evaluated: ${this.c.reason}` : this.c.what;
    return span;
  }
}

const shown = StateEffect.define<DecorationSet>();
const field = StateField.define<DecorationSet>({
  create: () => Decoration.none,
  update: (deco, tr) => {
    for (const e of tr.effects) if (e.is(shown)) return e.value;
    return deco.map(tr.changes);
  },
  provide: (f) => EditorView.decorations.from(f),
});

const THEME = EditorView.theme({
  ".st-mon": {
    display: "inline-block",
    marginLeft: "0.25em",
    padding: "0 0.3em",
    borderRadius: "3px",
    fontSize: "11px",
    lineHeight: "1.3",
    background: "#eef1f5",
    color: "#333",
    border: "1px solid #c8ccd2",
  },
  ".st-mon-true": { background: "#d3f5dc", color: "#14532d", borderColor: "#17803d" },
  ".st-mon-false": { background: "#f1f2f4", color: "#6b7280", borderColor: "#c8ccd2" },
  ".st-mon-forced": { outline: "2px solid #d97706" },
  ".st-mon-cond": { fontWeight: "bold", borderStyle: "dashed" },
  ".st-mon-none": { color: "#999", fontStyle: "italic" },
  ".st-mon-action": { cursor: "pointer" },
  ".st-mon-group .st-mon": { marginLeft: "0.2em" },
  ".st-mon-expand": { border: "none", background: "none", cursor: "pointer", padding: "0", fontSize: "11px" },
});

/** The editor extension the monitor draws into. */
export function monitorExtension(): Extension {
  return [field, THEME];
}

function decorations(
  view: EditorView,
  a: MonitorAnswer,
  expanded: Set<string>,
  on: OnValue | null,
  toggle: (p: string) => void,
) {
  const doc = view.state.doc;
  const at = (line: number, column: number): number | null => {
    if (line < 1 || line > doc.lines) return null;
    const l = doc.line(line);
    return Math.min(l.from + column - 1, l.to);
  };
  const ranges = [];
  for (const o of a.occurrences) {
    const pos = at(o.line, o.end_column);
    if (pos === null) continue;
    const fields = expanded.has(o.path) ? (a.fields[o.path] ?? []) : undefined;
    ranges.push(Decoration.widget({ widget: new ValueWidget(o, fields, on, toggle), side: 1 }).range(pos));
  }
  for (const c of a.conditions) {
    const pos = at(c.end_line, c.end_column);
    if (pos !== null) ranges.push(Decoration.widget({ widget: new ConditionWidget(c), side: 2 }).range(pos));
  }
  return Decoration.set(ranges, true);
}

/** Polls the monitor for the lines in view and draws the answer, until stop(). */
export class Monitor {
  private stopped = false;
  private poller: { stop(): void };
  private expanded = new Set<string>();
  last: MonitorAnswer | null = null;

  constructor(
    private readonly view: EditorView,
    private readonly fetch: (from: number, to: number, expand: string[]) => Promise<MonitorAnswer>,
    private readonly onValue: OnValue | null,
    onError: (e: unknown) => void,
  ) {
    this.poller = poll(() => this.run(), MONITOR_MS, onError, true);
  }

  private toggle = (path: string): void => {
    if (this.expanded.has(path)) this.expanded.delete(path);
    else this.expanded.add(path);
    this.redraw();
  };

  private redraw(): void {
    if (!this.last || this.stopped) return;
    const deco = decorations(this.view, this.last, this.expanded, this.onValue, this.toggle);
    this.view.dispatch({ effects: shown.of(deco) });
  }

  private async run(): Promise<void> {
    const { from, to } = this.view.viewport;
    const doc = this.view.state.doc;
    this.last = await this.fetch(doc.lineAt(from).number, doc.lineAt(to).number, [...this.expanded]);
    this.redraw();
  }

  stop(): void {
    this.stopped = true;
    this.poller.stop();
    if (this.view.dom.isConnected) this.view.dispatch({ effects: shown.of(Decoration.none) });
  }
}
