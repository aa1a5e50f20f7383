// saved-view.ts -- the trace configurations kept with the active set (GET /sets/{id}/scopes,
// docs/recorder.md "Trace configurations"): each with its trigger in words; Restore fills the form,
// Arm arms it as saved in one click, Delete removes it (operators); Save keeps the form's capture
// (and how the plot shows it) under a name.
import type { components } from "../api/schema";
import { h, setText } from "../ops/dom";
import { formatTime } from "../ops/units";
import { triggerText } from "./request";

type S = components["schemas"];
export type ScopeConfig = S["ScopeConfig"];
export type ScopeSaved = S["ScopeSaved"];
export type ScopeList = S["ScopeList"];

export interface SavedEnv {
  operator: boolean;
  restore(s: ScopeSaved): void;
  arm(s: ScopeSaved): void;
  remove(s: ScopeSaved): void;
  save(name: string): void;
}

export class SavedView {
  readonly el: HTMLElement;
  private list: HTMLElement;
  private head: HTMLElement;
  private nameInput: HTMLInputElement;
  private saveButton: HTMLButtonElement;

  constructor(private env: SavedEnv) {
    this.head = h("div", { class: "ops-sub", "data-testid": "saved-set" }, "looking for the active set…");
    this.list = h("tbody", {});
    this.nameInput = h("input", {
      class: "ops-edit",
      size: 18,
      placeholder: "a name",
      maxlength: 64,
      "data-testid": "save-name",
    });
    this.saveButton = h("button", { "data-testid": "save-scope" }, "Save with the set");
    this.saveButton.addEventListener("click", () => env.save(this.nameInput.value.trim()));
    this.el = h(
      "div",
      {},
      this.head,
      env.operator ? h("div", { class: "ops-actions" }, this.nameInput, this.saveButton) : null,
      h(
        "div",
        { class: "ops-scroll short" },
        h("table", { class: "ops-grid ops-dense", "data-testid": "saved-list" }, this.list),
      ),
    );
  }

  /** No set to save with (null: none activated through the agent) or the active set's list. */
  show(setId: string | null, list: ScopeList | null, why = ""): void {
    this.saveButton.disabled = setId === null;
    if (setId === null) {
      setText(
        this.head,
        why || "no set has been activated through the agent: configurations are kept with a stored set",
      );
      this.list.replaceChildren();
      return;
    }
    const n = list?.scopes.length ?? 0;
    setText(this.head, `kept with the active set ${setId}: ${n} of at most ${list?.max_configs ?? "?"}`);
    this.list.replaceChildren(
      ...(list && n
        ? list.scopes.map((s) => this.row(s))
        : [h("tr", {}, h("td", { class: "muted" }, "none saved with this set yet"))]),
    );
  }

  /** The name typed for saving (kept when the list is drawn again). */
  get name(): string {
    return this.nameInput.value.trim();
  }

  set name(v: string) {
    this.nameInput.value = v;
  }

  private row(s: ScopeSaved): HTMLElement {
    const c = s.config;
    const button = (label: string, testid: string, act: () => void, cls = "small") => {
      const b = h("button", { class: cls, "data-testid": `${testid}-${s.name}` }, label);
      b.addEventListener("click", act);
      return b;
    };
    return h(
      "tr",
      { "data-testid": `saved-${s.name}` },
      h("td", { class: "mono nowrap" }, s.name),
      h(
        "td",
        { class: "wrap" },
        c ? triggerText(c.capture.trigger) : h("span", { class: "bad" }, s.error ?? "unreadable"),
        c ? h("div", { class: "ops-sub" }, c.capture.variables.join(", ")) : null,
      ),
      h(
        "td",
        { class: "nowrap ops-sub", title: s.saved },
        `${s.by?.name ?? "?"}, ${s.saved ? formatTime(s.saved) : ""}`,
      ),
      h(
        "td",
        { class: "nowrap" },
        h(
          "span",
          { class: "ops-row-actions" },
          c ? button("Restore", "restore", () => this.env.restore(s)) : null,
          c && this.env.operator ? button("Arm", "arm-saved", () => this.env.arm(s), "small primary") : null,
          this.env.operator ? button("Delete", "delete-saved", () => this.env.remove(s), "small danger") : null,
        ),
      ),
    );
  }
}
