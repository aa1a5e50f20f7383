// activation-review.ts -- the one step before a set is activated (after an upload, or from the set
// history): irpd checks the stored set against what runs now (POST /sets/{id}/check), the page
// shows the slot table now and after beside the shared-variable diff and the modules kept,
// replaced, new and removed (module-fates-view.ts), and one button activates it
// (POST /sets/{id}/activate with mode "online", or "restart" once the operator confirmed that irpd
// restarts and the shared variables start at zero).  Checked once more right before activating:
// if what runs changed meanwhile, the new plan is shown instead and asked for again.
import { unwrap } from "../api/client";
import type { AppContext } from "../app/context";
import { type ActivationPlan, activationPlan, activationRequest, planKey, variableDiff } from "./activation";
import { errorText, h, setText } from "./dom";
import { renderModuleFates } from "./module-fates-view";
import { problemList } from "./problems-view";
import { renderSlotTable } from "./slot-table-view";
import { buildSlotTable, changedSlots } from "./timeline";
import type { Schedule, SetPublic, SwapReport, Validation } from "./types";
import { formatTime } from "./units";
import { renderVariableDiff } from "./variable-diff-view";

export class ActivationReview {
  readonly element: HTMLElement;
  private status = h("div", { class: "ops-sub", "data-testid": "plan-status" });
  private body = h("div", {});
  private error = h("div", { class: "ops-error", "data-testid": "plan-error", hidden: true, role: "alert" });
  private shownKey: string | null = null;
  private busy = false;
  private closed = false;

  constructor(
    private readonly ctx: AppContext,
    private readonly setId: string,
    private readonly onReport: (title: string, r: SwapReport) => void,
    private readonly onClose: () => void = () => {},
  ) {
    this.element = h(
      "div",
      { class: "ops-plan", "data-testid": "plan", "data-set": setId },
      h("h4", {}, "Activate set ", h("span", { class: "mono" }, setId)),
      this.status,
      this.body,
      this.error,
    );
    void this.check();
  }

  /** Stops answering (the review was replaced or the page left). */
  close(): void {
    this.closed = true;
  }

  private async fetchCheck(): Promise<SetPublic> {
    return unwrap(await this.ctx.api.POST("/api/v1/sets/{set_id}/check", { params: { path: { set_id: this.setId } } }));
  }

  private async fetchNow(): Promise<Schedule | null> {
    try {
      return unwrap(await this.ctx.api.GET("/api/v1/schedule")) as unknown as Schedule;
    } catch {
      return null; // the plan stands without the "now" table
    }
  }

  /** Asks irpd to check the set against what runs now and shows the plan. */
  async check(note = ""): Promise<void> {
    this.error.hidden = true;
    setText(this.status, "irpd is checking the set against what runs now…");
    this.body.replaceChildren();
    let set: SetPublic;
    let now: Schedule | null;
    try {
      [set, now] = await Promise.all([this.fetchCheck(), this.fetchNow()]);
    } catch (e) {
      if (this.closed) return;
      setText(this.status, "");
      this.fail(`check failed: ${errorText(e)}`);
      this.body.replaceChildren(this.actions(null));
      return;
    }
    if (this.closed) return;
    this.render(set.validation, now, note);
  }

  private fail(message: string): void {
    this.error.hidden = false;
    setText(this.error, message);
  }

  private render(v: Validation, now: Schedule | null, note: string): void {
    const plan = activationPlan(v);
    this.shownKey = planKey(v);
    setText(
      this.status,
      `${note ? `${note} ` : ""}checked against what runs now at ${formatTime(new Date().toISOString())}`,
    );
    const after = v.schedule ? buildSlotTable(v.schedule as unknown as Schedule) : null;
    const before = now ? buildSlotTable(now) : null;
    const changed = before && after ? changedSlots(before, after) : undefined;
    const vars =
      plan.kind === "restart" && !v.variables
        ? h(
            "div",
            { class: "ops-vardiff", "data-testid": "plan-variables" },
            h("div", { "data-testid": "plan-variables-summary" }, "shared variables: laid out afresh by the restart"),
          )
        : renderVariableDiff(variableDiff(v.variables));
    // h() leaves out the parts that are null
    this.body.replaceChildren(
      h(
        "div",
        {},
        plan.kind === "invalid" ? problemList(v) : null,
        plan.kind === "unchecked" ? h("div", { class: "warn" }, `not checked: ${plan.why}`) : null,
        v.warnings.length && plan.kind !== "unchecked"
          ? h("ul", { class: "ops-issues" }, ...v.warnings.map((w) => h("li", { class: "warn" }, w)))
          : null,
        h(
          "div",
          { class: "ops-plan-grid" },
          before
            ? h("div", {}, h("h5", {}, "slot table now"), renderSlotTable(before, { testid: "plan-before" }))
            : null,
          after
            ? h(
                "div",
                {},
                h(
                  "h5",
                  {},
                  "with this set",
                  changed?.size ? h("span", { class: "ops-sub" }, ` — ${changed.size} slot(s) differ`) : null,
                ),
                renderSlotTable(after, { testid: "plan-after", changed }),
              )
            : null,
          h("div", {}, h("h5", {}, "shared variables"), vars),
          v.modules ? h("div", {}, h("h5", {}, "modules"), renderModuleFates(v.modules)) : null,
        ),
        plan.kind === "restart" ? this.restartNotice(plan) : null,
        this.actions(plan),
      ),
    );
  }

  private restartNotice(plan: Extract<ActivationPlan, { kind: "restart" }>): HTMLElement {
    return h(
      "div",
      { class: "ops-confirm ops-restart", "data-testid": "plan-restart" },
      h("strong", {}, "Only a restart of irpd can run this set. "),
      h("span", { "data-testid": "plan-restart-reason" }, plan.reason),
      h(
        "div",
        {},
        "Expected downtime (last period of the running set to the first of this one): ",
        h("strong", { class: "num", "data-testid": "plan-downtime" }, plan.downtime),
        ". No module runs meanwhile, and the shared variables start afresh after the restart (at their initial values, zero in a .glb).",
      ),
    );
  }

  private actions(plan: ActivationPlan | null): HTMLElement {
    const restart = plan?.kind === "restart";
    const go = h(
      "button",
      { class: `primary${restart ? " danger" : ""}`, "data-testid": "plan-activate" },
      restart ? "Restart irpd onto this set" : "Activate: hot swap now",
    );
    const again = h("button", { "data-testid": "plan-recheck" }, "Check again");
    const cancel = h("button", { "data-testid": "plan-cancel" }, "Cancel");
    const box = h("input", { type: "checkbox", "data-testid": "plan-restart-confirm" });
    const gate = () => {
      const req = plan ? activationRequest(plan, box.checked) : { refused: "the set was not checked" };
      go.disabled = this.busy || "refused" in req;
      go.title = "refused" in req ? req.refused : "";
    };
    box.addEventListener("change", gate);
    gate();
    go.addEventListener("click", () => {
      if (plan) void this.activate(plan, box.checked, go);
    });
    again.addEventListener("click", () => void this.check());
    cancel.addEventListener("click", () => {
      this.close();
      this.onClose();
    });
    return h(
      "div",
      { class: "ops-actions" },
      restart
        ? h(
            "label",
            {},
            box,
            " I understand: irpd restarts, the cell stops for that time and the shared variables start at zero",
          )
        : null,
      go,
      again,
      cancel,
    );
  }

  private async activate(plan: ActivationPlan, restartConfirmed: boolean, button: HTMLButtonElement): Promise<void> {
    const req = activationRequest(plan, restartConfirmed);
    if ("refused" in req || this.busy) return;
    this.busy = true;
    button.disabled = true;
    this.error.hidden = true;
    setText(button, "checking again…");
    try {
      // what runs may have changed since the plan was shown: then show the new plan, send nothing
      const fresh = await this.fetchCheck();
      if (this.closed) return;
      if (planKey(fresh.validation) !== this.shownKey) {
        this.busy = false;
        this.render(
          fresh.validation,
          await this.fetchNow(),
          "What runs changed since the plan was shown: review it again.",
        );
        return;
      }
      setText(button, req.mode === "restart" ? "Restarting irpd…" : "Swapping…");
      const report = unwrap(
        await this.ctx.api.POST("/api/v1/sets/{set_id}/activate", {
          params: { path: { set_id: this.setId } },
          body: { mode: req.mode },
        }),
      );
      this.busy = false;
      this.close();
      this.onReport(
        `Set ${this.setId} ${req.mode === "restart" ? "activated by a restart of irpd" : "activated"}`,
        report,
      );
      this.ctx.notify(`activate ${this.setId}: done`);
      this.onClose();
    } catch (e) {
      this.busy = false;
      if (this.closed) return;
      this.fail(`activate ${this.setId} refused: ${errorText(e)}`);
      this.ctx.notify(`activate ${this.setId} refused: ${errorText(e)}`, "error");
      setText(button, plan.kind === "restart" ? "Restart irpd onto this set" : "Activate: hot swap now");
      button.disabled = false;
    }
  }
}
