// diagram.test.ts -- the live view's drawing (src/programs/diagram_view.ts): the LD and SFC symbols from
// a diagram as GET /programs/diagram answers it (a normally closed contact's slash, a set coil's S, an
// initial step's double border, a transition's condition), and one monitor answer painted on it: what
// conducts `pl-on`, what does not `pl-off`, a block pin's value (a TIME in ms), an active step with its
// time; null takes the colours away again.
import { describe, expect, it } from "vitest";
import { type Diagram, type DiagramMonitorAnswer, DiagramView } from "../../src/programs/diagram_view";

type El = Diagram["elements"][number];

function element(id: number, kind: string, over: Partial<El> = {}): El {
  return {
    id,
    kind,
    x: id * 50,
    y: 10,
    width: 21,
    height: 20,
    label: null,
    instance: null,
    negated: false,
    edge: "none",
    storage: "none",
    initial: false,
    order: 0,
    inputs: [{ name: null, x: id * 50, y: 20, negated: false, edge: "none" }],
    outputs: [{ name: null, x: id * 50 + 21, y: 20, negated: false, edge: "none" }],
    actions: [],
    condition: null,
    ...over,
  };
}

const DIAGRAM: Diagram = {
  set_id: "s",
  path: "plc.xml",
  pou: "main",
  kind: "PROGRAM",
  language: "LD",
  width: 400,
  height: 100,
  elements: [
    element(1, "leftPowerRail", { width: 10, height: 60, inputs: [] }),
    element(2, "contact", { label: "Start", negated: true }),
    element(3, "coil", { label: "Run", storage: "set" }),
    element(4, "block", {
      label: "TON",
      instance: "T1",
      width: 60,
      height: 50,
      inputs: [{ name: "PT", x: 200, y: 40, negated: false, edge: "none" }],
      outputs: [{ name: "Q", x: 260, y: 40, negated: false, edge: "none" }],
    }),
    element(5, "inVariable", { label: "T#2s", inputs: [] }),
    element(6, "step", { label: "Idle", initial: true, width: 60, height: 30 }),
    element(7, "transition", { condition: "NOT Start", height: 2 }),
  ],
  wires: [
    {
      from_id: 1,
      from_pin: null,
      to_id: 2,
      to_pin: null,
      points: [
        [100, 20],
        [60, 20],
      ],
    },
    {
      from_id: 2,
      from_pin: null,
      to_id: 3,
      to_pin: null,
      points: [
        [150, 20],
        [121, 20],
      ],
    },
    {
      from_id: 5,
      from_pin: null,
      to_id: 4,
      to_pin: "PT",
      points: [
        [200, 40],
        [271, 20],
      ],
    },
  ],
  text: null,
};

function g(view: DiagramView, id: number): SVGGElement {
  return view.element.querySelector(`[data-id="${id}"]`) as SVGGElement;
}

describe("the live view", () => {
  it("draws the symbols PLC engineers read", () => {
    const view = new DiagramView(DIAGRAM);
    expect(g(view, 2).textContent).toContain("Start");
    expect(g(view, 2).querySelectorAll("line").length).toBe(5); // two leads, two bars, the slash
    expect(g(view, 3).querySelectorAll("path").length).toBe(2); // ( and )
    expect(g(view, 3).textContent).toContain("S");
    expect(g(view, 4).textContent).toContain("TON");
    expect(g(view, 4).textContent).toContain("T1");
    expect(g(view, 4).textContent).toContain("PT");
    expect(g(view, 6).querySelectorAll("rect").length).toBe(2); // the initial step's double border
    expect(g(view, 7).textContent).toContain("NOT Start");
    expect(view.element.querySelectorAll('[data-testid="pl-wire"]').length).toBe(3);
  });

  it("paints a monitor answer and takes it away", () => {
    const view = new DiagramView(DIAGRAM);
    const answer: DiagramMonitorAnswer = {
      set_id: "s",
      layout_hash: "h",
      instance: "Main",
      flows: [
        { id: 1, pin: null, value: true, type: "BOOL", constant: true },
        { id: 2, pin: null, value: true, type: "BOOL", constant: false },
        { id: 3, pin: null, value: false, type: "BOOL", constant: false },
        { id: 5, pin: null, value: 2_000_000_000, type: "TIME", constant: true },
      ],
      elements: [{ id: 6, path: "Main.Idle", type: "STEP", value: true, active: true, time_ms: 1500, forced: false }],
      errors: [],
    };
    view.show(answer);
    expect(g(view, 2).getAttribute("class")).toContain("pl-on");
    expect(g(view, 3).getAttribute("class")).toContain("pl-off");
    expect(view.element.querySelector('[data-from="1"]')?.getAttribute("class")).toContain("pl-on");
    expect(view.element.querySelector('[data-from="2"]')?.getAttribute("class")).toContain("pl-on");
    expect(g(view, 4).textContent).toContain("2.0s"); // PT's value, from the wire's source
    expect(g(view, 5).querySelector(".pl-value")?.textContent).toBe(""); // a constant is not labelled
    expect(g(view, 6).getAttribute("class")).toContain("pl-active");
    expect(g(view, 6).textContent).toContain("T=1.5s");
    view.show(null);
    expect(g(view, 2).getAttribute("class")).toBe("pl-el pl-contact");
    expect(g(view, 6).textContent).not.toContain("T=");
  });
});
