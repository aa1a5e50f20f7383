// captures-view.ts -- the Scope page's list of captures (GET /captures, polled): state (idle, armed,
// triggered, done), the pre-trigger buffer's fill, shots taken, lost rows and the last message;
// operators disarm, arm again, trigger now and delete; anyone plots a shot or overlays it.
import type { components } from "../api/schema";
import { h, setText } from "../ops/dom";
import { lengthText, triggerText } from "./request";

export type CapturePublic = components["schemas"]["CapturePublic"];

export interface CapturesEnv {
  operator: boolean;
  act(what: string, id: string, call: "arm" | "disarm" | "trigger" | "delete"): void;
  /** plot shot `shot` of capture `id` (0: the newest), alone or over what is shown */
  plot(c: CapturePublic, shot: number, overlay: boolean): void;
  /** fill the form with this capture's request */
  edit(c: CapturePublic): void;
}

const STATE_LEVEL: Record<CapturePublic["state"], string> = {
  idle: "muted",
  armed: "warn",
  triggered: "bad",
  done: "good",
};

/** The fill of the pre-trigger buffer, as words. */
export function fillText(c: CapturePublic): string {
  if (c.state !== "armed") return c.pre_rows ? `${c.pre_rows} rows` : "–";
  return `${c.pre_filled} / ${c.pre_rows}`;
}

export class CapturesView {
  readonly el: HTMLElement;
  private body: HTMLElement;
  /** the shot picked in each capture's row (kept across polls) */
  private picked = new Map<string, string>();
  /** each capture's row and the cells a poll updates in place: a row is built again only when its
   * state, shots or request changed, so that a button is never replaced under the pointer */
  private rows = new Map<string, { sig: string; tr: HTMLElement; cells: Record<string, HTMLElement> }>();
  private order = "";

  constructor(private env: CapturesEnv) {
    this.body = h("tbody", {});
    this.el = h(
      "div",
      { class: "ops-scroll" },
      h(
        "table",
        { class: "ops-grid ops-dense", "data-testid": "capture-list" },
        h(
          "thead",
          {},
          h(
            "tr",
            {},
            ["capture", "state", "trigger", "before / after", "buffer", "shots", "lost", "shot"].map((t) =>
              h("th", {}, t),
            ),
            env.operator ? h("th", {}, "") : null,
          ),
        ),
        this.body,
      ),
    );
  }

  show(captures: CapturePublic[]): void {
    const seen = new Set<string>();
    for (const c of captures) {
      seen.add(c.id);
      const sig = JSON.stringify([c.state, c.shots.map((s) => s.shot), c.request]);
      let row = this.rows.get(c.id);
      if (!row || row.sig !== sig) {
        const built = this.row(c);
        if (row) row.tr.replaceWith(built.tr);
        row = { sig, ...built };
        this.rows.set(c.id, row);
      }
      const fill = row.cells.fill;
      setText(fill.firstChild as Element, fillText(c));
      const bar = fill.querySelector<HTMLElement>(".ops-bar-fill");
      if (bar) bar.style.width = `${c.pre_rows > 0 ? Math.min(100, (100 * c.pre_filled) / c.pre_rows) : 0}%`;
      setText(
        row.cells.shots,
        `${c.shots_taken}${c.request.repeat === 1 ? "" : ` of ${c.request.repeat === 0 ? "∞" : c.request.repeat}`}`,
      );
      setText(row.cells.lost, String(c.lost_rows));
      row.cells.lost.classList.toggle("bad", c.lost_rows > 0);
      setText(row.cells.message, c.message ?? "");
      row.tr.dataset.filled = String(c.pre_filled);
    }
    for (const id of [...this.rows.keys()]) if (!seen.has(id)) this.rows.delete(id);
    const order = captures.map((c) => c.id).join(" ");
    if (order !== this.order || !captures.length) {
      this.order = order;
      this.body.replaceChildren(
        ...(captures.length
          ? captures.map((c) => this.rows.get(c.id)!.tr)
          : [h("tr", {}, h("td", { colspan: 9, class: "muted" }, "no capture: set one up above and arm it"))]),
      );
    }
  }

  private row(c: CapturePublic): { tr: HTMLElement; cells: Record<string, HTMLElement> } {
    const req = c.request;
    const fill = h("td", { class: "num nowrap" }, h("span", { "data-testid": `fill-${c.id}` }, fillText(c)));
    if (c.state === "armed") fill.append(h("div", { class: "ops-bar small" }, h("div", { class: "ops-bar-fill" })));
    const cells = {
      fill,
      shots: h("td", { class: "num", "data-testid": `shots-${c.id}` }),
      lost: h("td", { class: "num" }),
      message: h("div", { class: "ops-sub warn", "data-testid": `message-${c.id}` }),
    };
    const tr = h(
      "tr",
      { "data-testid": `capture-${c.id}`, "data-state": c.state, "data-shots": c.shots.length },
      h(
        "td",
        { class: "nowrap", title: c.id },
        req.name || h("span", { class: "mono" }, c.id),
        req.name ? h("div", { class: "ops-sub mono" }, c.id) : null,
      ),
      h("td", { class: `state ${STATE_LEVEL[c.state]}`, "data-testid": `state-${c.id}` }, c.state),
      h(
        "td",
        { class: "scope-trigger" },
        h("span", { class: "mono" }, triggerText(req.trigger)),
        h("div", { class: "ops-sub" }, `capturing ${req.variables.join(", ")}`),
        cells.message,
      ),
      h("td", { class: "nowrap" }, `${lengthText(req.pre)} /`, h("br", {}), lengthText(req.post)),
      fill,
      cells.shots,
      cells.lost,
      h("td", { class: "nowrap" }, this.shotPicker(c)),
      this.env.operator ? h("td", { class: "scope-actions" }, this.actions(c)) : null,
    );
    return { tr, cells };
  }

  private shotPicker(c: CapturePublic): (HTMLElement | string)[] {
    if (!c.shots.length) return ["–"];
    const pick = h(
      "select",
      { class: "ops-edit", "data-testid": `shot-pick-${c.id}` },
      [...c.shots].reverse().map((s) => h("option", { value: s.shot }, `#${s.shot} (seq ${s.trigger_seq})`)),
    );
    const kept = this.picked.get(c.id);
    if (kept && c.shots.some((s) => String(s.shot) === kept)) pick.value = kept;
    pick.addEventListener("change", () => this.picked.set(c.id, pick.value));
    const plot = h("button", { class: "small primary", "data-testid": `plot-${c.id}` }, "Plot");
    const over = h(
      "button",
      { class: "small", "data-testid": `overlay-${c.id}`, title: "over the shot shown" },
      "Overlay",
    );
    plot.addEventListener("click", () => this.env.plot(c, Number(pick.value), false));
    over.addEventListener("click", () => this.env.plot(c, Number(pick.value), true));
    return [pick, h("br", {}), plot, " ", over];
  }

  private actions(c: CapturePublic): HTMLElement {
    const button = (label: string, testid: string, call: "arm" | "disarm" | "trigger" | "delete", cls = "small") => {
      const b = h("button", { class: cls, "data-testid": `${testid}-${c.id}` }, label);
      b.addEventListener("click", () => this.env.act(label.toLowerCase(), c.id, call));
      return b;
    };
    const live = c.state === "armed" || c.state === "triggered";
    const edit = h("button", { class: "small", "data-testid": `edit-${c.id}`, title: "fill the form with it" }, "Edit");
    edit.addEventListener("click", () => this.env.edit(c));
    return h(
      "span",
      { class: "ops-row-actions" },
      live ? button("Disarm", "disarm", "disarm") : button("Arm again", "rearm", "arm", "small primary"),
      c.state === "armed" ? button("Trigger now", "trigger", "trigger") : null,
      edit,
      button("Delete", "delete", "delete", "small danger"),
    );
  }
}

/** A line saying how many captures are in which state. */
export function countsText(captures: CapturePublic[]): string {
  const n = (s: CapturePublic["state"]) => captures.filter((c) => c.state === s).length;
  return `${captures.length} captures · ${n("armed")} armed · ${n("triggered")} triggered · ${n("done")} done`;
}
