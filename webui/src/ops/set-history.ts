// set-history.ts -- the stored sets (GET /sets, newest first) with activate and roll back
// (operator): activate opens the activation review (irpd's check against what runs now, then one
// button), roll back is asked for once more; both are answered with the swap report.
import { unwrap } from "../api/client";
import type { AppContext } from "../app/context";
import { ActivationReview } from "./activation-review";
import { errorText, h, setText } from "./dom";
import type { SetSummary, SwapReport } from "./types";
import { formatTime } from "./units";

export class SetHistory {
  readonly element: HTMLElement;
  private body = h("tbody", {});
  private info = h("span", { class: "ops-sub" });
  private error = h("div", { class: "ops-error", "data-testid": "set-history-error", hidden: true });
  private actionError = h("div", {
    class: "ops-error",
    "data-testid": "set-action-error",
    hidden: true,
    role: "alert",
  });
  private confirmBar = h("div", { class: "ops-confirm", "data-testid": "set-confirm", hidden: true });
  private reviewArea = h("div", { "data-testid": "set-review", hidden: true });
  private review: ActivationReview | null = null;
  private sets: SetSummary[] = [];
  private busy = false;
  private lastKey = "";

  constructor(
    private readonly ctx: AppContext,
    private readonly onReport: (title: string, r: SwapReport) => void,
  ) {
    const canAct = ctx.can("operator");
    const rollback = h("button", { "data-testid": "rollback" }, "Roll back…");
    rollback.addEventListener("click", () =>
      this.ask("Roll back to the set that was active before the current one?", "rollback", async () =>
        unwrap(await this.ctx.api.POST("/api/v1/sets/rollback")),
      ),
    );
    this.element = h(
      "section",
      { class: "panel ops-panel" },
      h("h3", {}, "Set history", this.info),
      canAct ? h("div", { class: "ops-actions" }, rollback) : null,
      this.confirmBar,
      this.reviewArea,
      this.actionError,
      this.error,
      h(
        "div",
        { class: "ops-scroll short" },
        h(
          "table",
          { class: "ops-grid ops-dense", "data-testid": "set-history" },
          h(
            "thead",
            {},
            h(
              "tr",
              {},
              h("th", {}, "id"),
              h("th", {}, "created"),
              h("th", {}, "by"),
              h("th", { class: "num" }, "files"),
              h("th", {}, "valid"),
              h("th", {}, "active"),
              canAct ? h("th", {}, "") : null,
            ),
          ),
          this.body,
        ),
      ),
    );
  }

  /** The Activate button for set `id` (for the upload result), or null for a viewer. */
  activateButton(id: string): HTMLElement | null {
    if (!this.ctx.can("operator")) return null;
    const b = h("button", { class: "small", "data-testid": `activate-${id}` }, "Activate…");
    b.addEventListener("click", () => this.activate(id));
    return b;
  }

  async refresh(): Promise<void> {
    try {
      this.sets = unwrap(await this.ctx.api.GET("/api/v1/sets"));
      this.error.hidden = true;
    } catch (e) {
      this.error.hidden = false;
      setText(this.error, `set history: ${errorText(e)} — retrying`);
      return;
    }
    const key = JSON.stringify(this.sets);
    if (key === this.lastKey) return;
    this.lastKey = key;
    setText(this.info, ` — ${this.sets.length} stored, newest first`);
    const canAct = this.ctx.can("operator");
    this.body.replaceChildren(
      ...(this.sets.length
        ? this.sets.map((s) =>
            h(
              "tr",
              { "data-testid": `set-row-${s.id}`, class: s.active ? "active" : null },
              h("td", { class: "mono" }, s.id),
              h("td", { class: "mono nowrap", title: s.created }, formatTime(s.created)),
              h("td", {}, s.by?.name ?? "–"),
              h("td", { class: "num" }, String(s.files)),
              h(
                "td",
                { class: `state ${s.valid === true ? "good" : s.valid === false ? "bad" : "warn"}` },
                s.valid === true ? "valid" : s.valid === false ? "invalid" : "not checked",
              ),
              h("td", { class: s.active ? "state good" : "" }, s.active ? "active" : ""),
              canAct ? h("td", {}, !s.active && s.valid !== false ? this.activateButton(s.id) : null) : null,
            ),
          )
        : [
            h(
              "tr",
              {},
              h(
                "td",
                { colspan: 7, class: "ops-sub" },
                "no set stored yet (sets started from the command line are not in the store)",
              ),
            ),
          ]),
    );
  }

  /** The activation review of set `id` (for the upload result), or null for a viewer; `onClose` when it is done or cancelled. */
  reviewOf(id: string, onClose: () => void = () => {}): HTMLElement | null {
    if (!this.ctx.can("operator")) return null;
    return new ActivationReview(this.ctx, id, (title, r) => this.reported(title, r), onClose).element;
  }

  /** Opens the activation review of set `id` above the history (one at a time). */
  activate(id: string): void {
    if (this.busy) return;
    this.review?.close();
    this.confirmBar.hidden = true;
    this.actionError.hidden = true;
    const review = new ActivationReview(
      this.ctx,
      id,
      (title, r) => this.reported(title, r),
      () => {
        if (this.review !== review) return;
        this.review = null;
        this.reviewArea.hidden = true;
        this.reviewArea.replaceChildren();
      },
    );
    this.review = review;
    this.reviewArea.replaceChildren(review.element);
    this.reviewArea.hidden = false;
    this.reviewArea.scrollIntoView?.({ block: "nearest" });
  }

  private reported(title: string, r: SwapReport): void {
    this.onReport(title, r);
    this.lastKey = "";
    void this.refresh();
  }

  private ask(question: string, what: string, act: () => Promise<SwapReport>): void {
    if (this.busy) return;
    this.review?.close();
    this.review = null;
    this.reviewArea.hidden = true;
    this.reviewArea.replaceChildren();
    const yes = h("button", { class: "primary danger", "data-testid": "set-confirm-yes" }, "Confirm");
    const no = h("button", { "data-testid": "set-confirm-no" }, "Cancel");
    this.confirmBar.hidden = false;
    this.actionError.hidden = true;
    this.confirmBar.replaceChildren(h("span", {}, question, " "), yes, " ", no);
    this.confirmBar.scrollIntoView?.({ block: "nearest" });
    no.addEventListener("click", () => {
      this.confirmBar.hidden = true;
    });
    yes.addEventListener("click", async () => {
      this.busy = true;
      yes.disabled = true;
      no.disabled = true;
      setText(yes, "Swapping…");
      try {
        const report = await act();
        this.confirmBar.hidden = true;
        this.actionError.hidden = true;
        this.onReport("Rolled back", report);
        this.ctx.notify(`${what}: done`);
      } catch (e) {
        this.confirmBar.hidden = true;
        this.actionError.hidden = false;
        setText(this.actionError, `${what} refused: ${errorText(e)}`);
        this.ctx.notify(`${what} refused: ${errorText(e)}`, "error");
      } finally {
        this.busy = false;
        this.lastKey = "";
        void this.refresh();
      }
    });
  }
}
