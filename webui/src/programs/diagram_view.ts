// diagram_view.ts -- the live view of an LD, FBD or SFC POU (docs/programming.md "The live view"): the
// diagram of GET /programs/diagram drawn as SVG at the file's own positions, with the symbols PLC
// engineers read: power rails, contacts -| |- -|/|- -|P|- -|N|-, coils -( )- -(/)- -(S)- -(R)-, blocks
// as boxes with their pin names, variables, connectors, jumps; SFC steps as boxes (the initial one
// with a double border), transitions as bars with their condition, action blocks with their
// qualifiers, divergences as single (selection) or double (simultaneous) lines.  show() paints one
// answer of POST /programs/diagram/monitor on it: wires and elements that conduct get `pl-on`, those
// that do not `pl-off`; a value beside each block pin and variable; active steps `pl-active` with
// their time.  Nothing is evaluated here: every value comes from the agent.
import type { components } from "../api/schema";
import { svgEl as el } from "../ops/svg";
import { type Value, valueText } from "./values";

export type Diagram = components["schemas"]["Diagram"];
export type DiagramMonitorAnswer = components["schemas"]["DiagramMonitorAnswer"];
type Element = components["schemas"]["DiagramElement"];
type Pin = components["schemas"]["DiagramPin"];

const MARGIN = 20;
const FONT = 11; // px, in the file's units (its coordinates are pixels in the editors that wrote it)
const CHAR = 6.7; // the width of a character of FONT px in a monospace font

function line(x1: number, y1: number, x2: number, y2: number, cls = "pl-line"): SVGLineElement {
  return el("line", { x1, y1, x2, y2, class: cls });
}

function text(x: number, y: number, s: string, anchor = "middle", cls = "pl-text"): SVGTextElement {
  return el("text", { x, y, "text-anchor": anchor, class: cls }, s);
}

/** The letter inside a contact or coil: / negated, P / N an edge, S / R a set / reset coil. */
function mark(e: Element): string {
  if (e.storage === "set") return "S";
  if (e.storage === "reset") return "R";
  if (e.edge === "rising") return "P";
  if (e.edge === "falling") return "N";
  return e.negated ? "/" : "";
}

function contact(g: SVGGElement, e: Element): void {
  const mid = e.y + e.height / 2;
  const a = e.x + Math.min(6, e.width / 3);
  const b = e.x + e.width - Math.min(6, e.width / 3);
  g.append(line(e.x, mid, a, mid), line(b, mid, e.x + e.width, mid));
  g.append(line(a, e.y, a, e.y + e.height, "pl-line pl-bar"), line(b, e.y, b, e.y + e.height, "pl-line pl-bar"));
  const m = mark(e);
  if (m === "/") g.append(line(b - 1, e.y + 2, a + 1, e.y + e.height - 2));
  else if (m) g.append(text((a + b) / 2, mid + 4, m, "middle", "pl-text pl-mark"));
}

function coil(g: SVGGElement, e: Element): void {
  const mid = e.y + e.height / 2;
  const edge = Math.min(2, e.width / 8); // where "(" and ")" bulge to, from the element's ends
  const inner = Math.min(7, e.width / 3); // where they end, top and bottom
  g.append(line(e.x, mid, e.x + edge, mid), line(e.x + e.width - edge, mid, e.x + e.width, mid));
  // "(" and ")": two arcs (quadratic curves) through the top and bottom of the element
  const l = e.x + inner;
  const r = e.x + e.width - inner;
  const bulge = 2 * edge - inner; // the control point that puts a curve's middle at `edge`
  const curve = (x: number, cx: number) => `M ${x} ${e.y} Q ${cx} ${mid} ${x} ${e.y + e.height}`;
  g.append(el("path", { d: curve(l, e.x + bulge), class: "pl-line pl-bar" }));
  g.append(el("path", { d: curve(r, e.x + e.width - bulge), class: "pl-line pl-bar" }));
  const m = mark(e);
  if (m === "/") g.append(line(r - 1, e.y + 3, l + 1, e.y + e.height - 3));
  else if (m) g.append(text(e.x + e.width / 2, mid + 4, m, "middle", "pl-text pl-mark"));
}

function pinName(pin: Pin): string {
  return pin.name ?? "";
}

function block(g: SVGGElement, e: Element): void {
  g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, class: "pl-box" }));
  g.append(text(e.x + e.width / 2, e.y + FONT + 2, e.label ?? "?", "middle", "pl-text pl-type"));
  if (e.instance) g.append(text(e.x + e.width / 2, e.y - 4, e.instance, "middle", "pl-text pl-name"));
  for (const p of e.inputs) {
    g.append(text(e.x + 4, p.y + 4, pinName(p), "start", "pl-text pl-pin"));
    if (p.negated) g.append(el("circle", { cx: p.x - 3, cy: p.y, r: 3, class: "pl-box" }));
    if (p.edge === "rising" || p.edge === "falling")
      g.append(text(e.x + 2, p.y - 3, p.edge === "rising" ? ">" : "<", "start", "pl-text pl-mark"));
  }
  for (const p of e.outputs) {
    g.append(text(e.x + e.width - 4, p.y + 4, pinName(p), "end", "pl-text pl-pin"));
    if (p.negated) g.append(el("circle", { cx: p.x + 3, cy: p.y, r: 3, class: "pl-box" }));
  }
}

function variable(g: SVGGElement, e: Element): void {
  g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, rx: 4, class: "pl-box pl-var" }));
  g.append(text(e.x + e.width / 2, e.y + e.height / 2 + 4, e.label ?? "", "middle", "pl-text pl-name"));
}

function connector(g: SVGGElement, e: Element): void {
  // a connector points out of the network (> at its right), a continuation into it (> at its left)
  const { x, y, width: w, height: h } = e;
  const tip = Math.min(10, w / 4);
  const d =
    e.kind === "connector"
      ? `M ${x} ${y} H ${x + w - tip} L ${x + w} ${y + h / 2} L ${x + w - tip} ${y + h} H ${x} Z`
      : `M ${x} ${y} H ${x + w} V ${y + h} H ${x} L ${x + tip} ${y + h / 2} Z`;
  g.append(el("path", { d, class: "pl-box pl-var" }));
  g.append(text(x + w / 2, y + h / 2 + 4, e.label ?? "", "middle", "pl-text pl-name"));
}

function step(g: SVGGElement, e: Element): void {
  g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, class: "pl-box pl-step-box" }));
  if (e.initial)
    g.append(el("rect", { x: e.x + 3, y: e.y + 3, width: e.width - 6, height: e.height - 6, class: "pl-box" }));
  g.append(text(e.x + e.width / 2, e.y + e.height / 2 + 4, e.label ?? "", "middle", "pl-text pl-name"));
}

function transition(g: SVGGElement, e: Element): void {
  const mid = e.y + e.height / 2;
  const cx = e.x + e.width / 2;
  g.append(line(cx, e.y - 6, cx, e.y + e.height + 6));
  g.append(line(e.x, mid, e.x + e.width, mid, "pl-line pl-transition"));
  if (e.condition) g.append(text(e.x + e.width + 6, mid + 4, e.condition, "start", "pl-text pl-cond"));
}

function actionBlock(g: SVGGElement, e: Element): void {
  const rows = Math.max(1, e.actions.length);
  const rowH = e.height / rows;
  const quals = e.actions.map((a) => (a.duration ? `${a.qualifier} ${a.duration}` : a.qualifier));
  const q = Math.min(Math.max(24, ...quals.map((x) => x.length * CHAR + 8)), e.width / 2);
  g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, class: "pl-box" }));
  g.append(line(e.x + q, e.y, e.x + q, e.y + e.height));
  e.actions.forEach((a, i) => {
    const y = e.y + i * rowH;
    if (i) g.append(line(e.x, y, e.x + e.width, y));
    g.append(text(e.x + q / 2, y + rowH / 2 + 4, quals[i], "middle", "pl-text pl-qual"));
    g.append(text(e.x + q + 4, y + rowH / 2 + 4, a.name ?? a.text ?? "", "start", "pl-text pl-name"));
  });
}

function divergence(g: SVGGElement, e: Element): void {
  const y = e.y;
  const simultaneous = e.kind.startsWith("simultaneous");
  g.append(line(e.x, y, e.x + e.width, y, "pl-line pl-bar"));
  if (simultaneous) g.append(line(e.x, y + 3, e.x + e.width, y + 3, "pl-line pl-bar"));
}

function jumpStep(g: SVGGElement, e: Element): void {
  const { x, y, width: w, height: h } = e;
  g.append(el("path", { d: `M ${x} ${y} H ${x + w} L ${x + w / 2} ${y + h} Z`, class: "pl-box pl-arrow" }));
  g.append(text(x + w + 4, y + h, e.label ?? "", "start", "pl-text pl-name"));
}

function misc(g: SVGGElement, e: Element): void {
  const mid = e.y + e.height / 2 + 4;
  if (e.kind === "leftPowerRail" || e.kind === "rightPowerRail")
    g.append(el("rect", { x: e.x, y: e.y, width: Math.max(e.width, 3), height: e.height, class: "pl-rail" }));
  else if (e.kind === "jump") g.append(text(e.x, mid, `>>${e.label ?? ""}`, "start", "pl-text pl-name"));
  else if (e.kind === "label") g.append(text(e.x, mid, `${e.label ?? ""}:`, "start", "pl-text pl-name"));
  else if (e.kind === "return") g.append(text(e.x, mid, "<RETURN>", "start", "pl-text pl-name"));
  else if (e.kind === "comment") {
    g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, class: "pl-comment" }));
    // wrapped at the box's width, and the lines that do not fit in its height left out
    const perLine = Math.max(1, Math.floor((e.width - 8) / CHAR));
    const lines = Math.max(1, Math.floor((e.height - 4) / (FONT + 2)));
    const t = text(e.x + 4, e.y + FONT + 3, "", "start", "pl-text pl-comment-text");
    wrap(e.label ?? "", perLine)
      .slice(0, lines)
      .forEach((l, i) => {
        t.append(el("tspan", { x: e.x + 4, dy: i ? FONT + 2 : 0 }, l));
      });
    g.append(t);
  } else g.append(el("rect", { x: e.x, y: e.y, width: e.width, height: e.height, class: "pl-box" }));
}

/** Words in lines of at most `width` characters (a longer word cut). */
function wrap(s: string, width: number): string[] {
  const out: string[] = [];
  let cur = "";
  for (const word of s.split(/\s+/).filter(Boolean)) {
    for (let w = word; w; w = w.slice(width)) {
      const part = w.slice(0, width);
      if (cur && cur.length + 1 + part.length > width) {
        out.push(cur);
        cur = part;
      } else cur = cur ? `${cur} ${part}` : part;
      if (w.length <= width) break;
    }
  }
  if (cur) out.push(cur);
  return out;
}

const DRAW: Record<string, (g: SVGGElement, e: Element) => void> = {
  contact,
  coil,
  block,
  inVariable: variable,
  outVariable: variable,
  inOutVariable: variable,
  connector,
  continuation: connector,
  step,
  transition,
  actionBlock,
  selectionDivergence: divergence,
  selectionConvergence: divergence,
  simultaneousDivergence: divergence,
  simultaneousConvergence: divergence,
  jumpStep,
};

function key(id: number, pin: string | null | undefined): string {
  return `${id}/${pin ?? ""}`;
}

/** The CSS class a value gives what carries it: pl-on / pl-off for a BOOL, nothing for a number. */
function flowClass(v: Value): string {
  return typeof v === "boolean" ? (v ? " pl-on" : " pl-off") : "";
}

export class DiagramView {
  readonly element: SVGSVGElement;
  private groups = new Map<number, SVGGElement>();
  private wires: { path: SVGPolylineElement; from: string }[] = [];
  private labels = new Map<string, SVGTextElement>(); // values beside pins: "id/pin"
  private stepTimes = new Map<number, SVGTextElement>();
  private types = new Map<string, string>(); // the IEC type of each flow of the last answer
  private constants = new Set<string>(); // the flows that are constants (a literal drawn as a variable)

  constructor(readonly diagram: Diagram) {
    const w = diagram.width + 2 * MARGIN;
    const h = diagram.height + 2 * MARGIN;
    this.element = el("svg", {
      class: "pl-svg",
      "data-testid": "pl-svg",
      viewBox: `${-MARGIN} ${-MARGIN} ${w} ${h}`,
      width: w,
      height: h,
    });
    const wires = el("g", { class: "pl-wires" });
    for (const wire of diagram.wires) {
      const path = el("polyline", {
        points: wire.points.map(([x, y]) => `${x},${y}`).join(" "),
        class: "pl-wire",
        "data-testid": "pl-wire",
        "data-from": wire.from_id,
        "data-to": wire.to_id,
      });
      this.wires.push({ path, from: key(wire.from_id, wire.from_pin) });
      wires.append(path);
    }
    const elements = el("g", { class: "pl-elements" });
    for (const e of diagram.elements) {
      const g = el("g", {
        class: `pl-el pl-${e.kind}`,
        "data-testid": "pl-element",
        "data-id": e.id,
        "data-kind": e.kind,
      });
      if (e.label && e.kind !== "comment") g.append(el("title", {}, `${e.kind} ${e.label} (localId ${e.id})`));
      (DRAW[e.kind] ?? misc)(g, e);
      if (e.kind === "contact" || e.kind === "coil")
        g.append(text(e.x + e.width / 2, e.y - 4, e.label ?? "", "middle", "pl-text pl-name"));
      for (const p of e.kind === "block" ? [...e.inputs, ...e.outputs] : []) {
        const out = e.outputs.includes(p);
        const label = text(out ? p.x + 3 : p.x - 3, p.y - 3, "", out ? "start" : "end", "pl-text pl-value");
        this.labels.set(`${out ? "out" : "in"}:${key(e.id, p.name)}`, label);
        g.append(label);
      }
      if (["inVariable", "inOutVariable", "outVariable"].includes(e.kind)) {
        const label = text(e.x + e.width / 2, e.y - 3, "", "middle", "pl-text pl-value");
        this.labels.set(`var:${e.id}`, label);
        g.append(label);
      }
      if (e.kind === "step") {
        const t = text(e.x + e.width / 2, e.y + e.height + FONT + 1, "", "middle", "pl-text pl-value");
        this.stepTimes.set(e.id, t);
        g.append(t);
      }
      this.groups.set(e.id, g);
      elements.append(g);
    }
    this.element.append(wires, elements);
  }

  /** Paints one monitor answer (null: monitoring stopped, everything back to its drawing). */
  show(answer: DiagramMonitorAnswer | null): void {
    const flows = new Map<string, Value>();
    const reasons = new Map<string, string>();
    this.types.clear();
    this.constants.clear();
    for (const f of answer?.flows ?? []) {
      flows.set(key(f.id, f.pin), f.value);
      if (f.type) this.types.set(key(f.id, f.pin), f.type);
      if (f.constant) this.constants.add(key(f.id, f.pin));
      if (f.reason) reasons.set(key(f.id, f.pin), f.reason);
    }
    for (const w of this.wires) w.path.setAttribute("class", `pl-wire${flowClass(flows.get(w.from))}`);
    // a wire that conducts is drawn over those that do not where their polylines overlap (a branch)
    for (const w of this.wires) if (flows.get(w.from) === true) w.path.parentNode?.appendChild(w.path);
    const values = new Map((answer?.elements ?? []).map((v) => [v.id, v]));
    for (const e of this.diagram.elements) {
      const g = this.groups.get(e.id);
      if (!g) continue;
      const v = values.get(e.id);
      let cls = `pl-el pl-${e.kind}`;
      if (["contact", "coil", "leftPowerRail"].includes(e.kind)) cls += flowClass(flows.get(key(e.id, null)));
      if (e.kind === "step" && v) cls += v.active ? " pl-active" : " pl-off";
      if (v?.forced) cls += " pl-forced";
      g.setAttribute("class", cls);
      if (e.kind === "step") {
        const t = this.stepTimes.get(e.id);
        if (t)
          t.textContent = v?.active && v.time_ms !== null && v.time_ms !== undefined ? `T=${fmtMs(v.time_ms)}` : "";
      }
      for (const p of e.kind === "block" ? e.outputs : [])
        this.label(`out:${key(e.id, p.name)}`, flows, key(e.id, p.name), reasons);
      for (const p of e.kind === "block" ? e.inputs : []) {
        const wire = this.diagram.wires.find((w) => w.to_id === e.id && w.to_pin === p.name);
        this.label(`in:${key(e.id, p.name)}`, flows, wire ? key(wire.from_id, wire.from_pin) : "", reasons);
      }
      const varLabel = this.labels.get(`var:${e.id}`);
      if (varLabel) {
        const shown = v ? v.value : this.constants.has(key(e.id, null)) ? undefined : flows.get(key(e.id, null));
        const type = v ? null : this.types.get(key(e.id, null));
        varLabel.textContent = answer && shown !== undefined ? typedText(shown, type) + (v?.forced ? " F" : "") : "";
        varLabel.setAttribute("class", `pl-text pl-value${flowClass(shown)}`);
      }
    }
  }

  private label(name: string, flows: Map<string, Value>, from: string, reasons: Map<string, string>): void {
    const t = this.labels.get(name);
    if (!t) return;
    const v = flows.get(from);
    t.textContent = flows.has(from) ? typedText(v, this.types.get(from)) : "";
    t.setAttribute("class", `pl-text pl-value${flowClass(v)}`);
    const why = reasons.get(from);
    if (why) t.append(el("title", {}, why));
  }
}

/** A value as shown on the diagram: a TIME (nanoseconds) in ms or s, the rest as the ST monitor shows it. */
function typedText(v: Value, type: string | null | undefined): string {
  return type === "TIME" && typeof v === "number" ? fmtMs(v / 1e6) : valueText(v);
}

function fmtMs(ms: number): string {
  return ms < 1000 ? `${Math.round(ms)}ms` : `${(ms / 1000).toFixed(1)}s`;
}
