// form-view.ts -- the Scope page's capture form: the variables captured (chips; + in the tree adds
// one), the trigger (1 to 4 conditions joined by AND or OR, or an event), the pre- and post-trigger
// lengths, single or repeated, and its name.  It keeps a CaptureForm (request.ts) as typed; what is
// sent is built from it by buildRequest().
import { h } from "../ops/dom";
import {
  type CaptureForm,
  type ConditionForm,
  emptyCondition,
  emptyForm,
  SEVERITIES,
  TRIGGER_KINDS,
  UNITS,
} from "./request";

const TRIGGER_TEXT: Record<(typeof TRIGGER_KINDS)[number], string> = {
  condition: "conditions on variables",
  alarm: "an alarm raised",
  fault: "a fault (a module threw, the set stopped)",
  swap: "a hot swap",
  manual: "by hand (Trigger now)",
};

type Options = readonly (string | [string, string])[];

function select(testid: string, options: Options, value: string, onChange: (v: string) => void): HTMLSelectElement {
  const s = h(
    "select",
    { class: "ops-edit", "data-testid": testid },
    options.map((o) => (Array.isArray(o) ? h("option", { value: o[0] }, o[1]) : h("option", { value: o }, o))),
  );
  s.value = value;
  s.addEventListener("change", () => onChange(s.value));
  return s;
}

function input(
  testid: string,
  value: string,
  onInput: (v: string) => void,
  attrs: Record<string, string | number> = {},
) {
  const e = h("input", { class: "ops-edit", "data-testid": testid, value, ...attrs });
  e.addEventListener("input", () => onInput(e.value));
  return e;
}

export interface FormEnv {
  /** the maximum of conditions (from GET /captures/limits; null until it came) */
  maxConditions(): number | null;
  /** the datalist ids to offer paths from: every variable, numeric ones */
  lists: { all: string; numeric: string };
  /** a variable's tooltip, its path and type (paths.ts varTitle) */
  describe(path: string): string;
  changed(): void;
}

export class CaptureFormView {
  readonly el: HTMLElement;
  private state: CaptureForm = emptyForm();

  constructor(private env: FormEnv) {
    this.el = h("div", { class: "scope-form", "data-testid": "capture-form" });
    this.render();
  }

  get form(): CaptureForm {
    return this.state;
  }

  /** Fills the form (a saved configuration restored, a capture to arm again). */
  set(form: CaptureForm): void {
    this.state = structuredClone(form);
    this.render();
  }

  /** Adds a variable to capture (the tree's +); a condition without a variable gets it too. */
  addVariable(path: string): void {
    if (!this.state.variables.includes(path)) this.state.variables.push(path);
    const empty = this.state.conditions.find((c) => !c.variable.trim());
    if (empty) empty.variable = path;
    this.render();
  }

  /** An input's handler: sets the form's field as typed. */
  private field<K extends keyof CaptureForm>(k: K): (v: string) => void {
    return (v) => {
      this.state[k] = v as CaptureForm[K];
      this.change();
    };
  }

  private change(structural = false): void {
    if (structural) this.render();
    this.env.changed();
  }

  private render(): void {
    const f = this.state;
    const chips = h(
      "span",
      { class: "chips", "data-testid": "capture-vars" },
      f.variables.map((p) => {
        const x = h("button", { class: "small link", title: "remove", "data-testid": `capvar-remove-${p}` }, "×");
        x.addEventListener("click", () => {
          f.variables = f.variables.filter((v) => v !== p);
          this.change(true);
        });
        return h("span", { class: "chip", title: this.env.describe(p), "data-testid": `capvar-${p}` }, p, x);
      }),
    );
    const add = h("input", {
      class: "ops-edit",
      list: this.env.lists.all,
      placeholder: "add a variable…",
      size: 28,
      "data-testid": "capture-var-add",
    });
    add.addEventListener("change", () => {
      const p = add.value.trim();
      add.value = "";
      if (p) this.addVariable(p);
      this.env.changed();
    });
    const trigger = select(
      "trigger-kind",
      TRIGGER_KINDS.map((k) => [k, TRIGGER_TEXT[k]] as [string, string]),
      f.trigger,
      (v) => {
        f.trigger = v as CaptureForm["trigger"];
        if (f.trigger === "condition" && f.conditions.length === 0) f.conditions.push(emptyCondition(f.variables[0]));
        this.change(true);
      },
    );
    this.el.replaceChildren(
      h("div", { class: "ops-actions" }, h("span", { class: "scope-label" }, "capture"), chips, add),
      h("div", { class: "ops-actions" }, h("span", { class: "scope-label" }, "trigger"), trigger),
      this.triggerPart(),
      h(
        "div",
        { class: "ops-actions" },
        h("span", { class: "scope-label" }, "before"),
        input("pre", f.pre, this.field("pre"), { size: 7 }),
        select("pre-unit", UNITS, f.preUnit, this.field("preUnit")),
        h("span", { class: "scope-label" }, "after"),
        input("post", f.post, this.field("post"), { size: 7 }),
        select("post-unit", UNITS, f.postUnit, this.field("postUnit")),
        h("span", { class: "scope-label" }, "shots"),
        input("repeat", f.repeat, this.field("repeat"), {
          size: 4,
          title: "1: a single shot; N: N shots, armed again after each; 0: until disarmed",
        }),
        h("span", { class: "ops-sub" }, "(1 single, 0 until disarmed)"),
        h("span", { class: "scope-label" }, "name"),
        input("capture-name", f.name, this.field("name"), { size: 16, placeholder: "optional" }),
      ),
    );
  }

  private triggerPart(): HTMLElement {
    const f = this.state;
    if (f.trigger === "alarm")
      return h(
        "div",
        { class: "ops-actions" },
        h("span", { class: "scope-label" }, "alarm"),
        input("alarm-key", f.alarmKey, this.field("alarmKey"), {
          size: 14,
          placeholder: "key, e.g. main/8 (any)",
        }),
        "severity at least",
        select("alarm-severity", [["", "any"], ...SEVERITIES], f.alarmSeverity, (v) => {
          f.alarmSeverity = v as CaptureForm["alarmSeverity"];
          this.change();
        }),
      );
    if (f.trigger !== "condition") return h("div", { hidden: true });
    const most = this.env.maxConditions();
    const addCond = h("button", { class: "small", "data-testid": "add-condition" }, "+ condition");
    addCond.disabled = most !== null && f.conditions.length >= most;
    addCond.title = most !== null ? `at most ${most} conditions` : "";
    addCond.addEventListener("click", () => {
      f.conditions.push(emptyCondition(f.variables[0]));
      this.change(true);
    });
    const combine = select(
      "combine",
      [
        ["and", "all of (AND)"],
        ["or", "any of (OR)"],
      ],
      f.combine,
      this.field("combine"),
    );
    return h(
      "div",
      { class: "scope-conditions", "data-testid": "conditions" },
      f.conditions.length > 1 ? h("div", { class: "ops-actions" }, combine) : null,
      f.conditions.map((c, i) => this.conditionRow(c, i)),
      h("div", { class: "ops-actions" }, addCond),
    );
  }

  private conditionRow(c: ConditionForm, i: number): HTMLElement {
    const id = (s: string) => `cond-${i}-${s}`;
    const set =
      <K extends keyof ConditionForm>(k: K, structural = false) =>
      (v: string) => {
        c[k] = v as ConditionForm[K];
        this.change(structural);
      };
    const remove = h("button", { class: "small", "data-testid": id("remove"), title: "remove this condition" }, "×");
    remove.addEventListener("click", () => {
      this.state.conditions.splice(i, 1);
      this.change(true);
    });
    const hold = () => [" for ", input(id("hold"), c.hold, set("hold"), { size: 4 }), " rows"];
    const fields =
      c.kind === "edge"
        ? [
            select(id("direction"), ["rising", "falling", "either"], c.direction, set("direction")),
            " through ",
            input(id("threshold"), c.threshold, set("threshold"), { size: 7 }),
          ]
        : c.kind === "level"
          ? [
              select(id("compare"), ["above", "below", "equal"], c.compare, set("compare", true)),
              input(id("value"), c.value, set("value"), { size: 7 }),
              c.compare === "equal"
                ? [" ± ", input(id("tolerance"), c.tolerance, set("tolerance"), { size: 5 })]
                : null,
              hold(),
            ]
          : [
              select(id("where"), ["inside", "outside"], c.where, set("where")),
              " [",
              input(id("low"), c.low, set("low"), { size: 6 }),
              ", ",
              input(id("high"), c.high, set("high"), { size: 6 }),
              "]",
              hold(),
            ];
    return h(
      "div",
      { class: "ops-actions scope-condition", "data-testid": id("row") },
      input(id("variable"), c.variable, set("variable"), {
        list: this.env.lists.numeric,
        size: 26,
        placeholder: "a numeric variable",
      }),
      select(
        id("kind"),
        [
          ["edge", "edge"],
          ["level", "level"],
          ["window", "window"],
        ],
        c.kind,
        set("kind", true),
      ),
      fields.flat(),
      remove,
    );
  }
}
