// change-panel.ts -- pending module changes: checked on the client as they are typed, then by a
// debounced dry run (POST /modules/changes dry_run=true, the authoritative answer); "Apply" shows
// the new slot table beside the old, "Confirm" applies them in one hot swap.
import { ApiError, unwrap } from "../api/client";
import type { AppContext } from "../app/context";
import { errorText, h, setClass, setText } from "./dom";
import type { ModuleTable } from "./module-table";
import { renderSlotTable } from "./slot-table-view";
import { buildSlotTable, changedSlots } from "./timeline";
import type { ChangesReport, ModuleChange, Schedule, SwapReport } from "./types";
import { formatNs, formatPercent } from "./units";
import { type Check, checkEdits, DEFAULT_LIMITS, distinctMessages, type Limits } from "./validate";

const DEBOUNCE_MS = 400;

type Dry =
  | { key: string; state: "pending" }
  | { key: string; state: "ok"; report: ChangesReport }
  | { key: string; state: "refused" | "failed"; message: string; at?: number };

const RETRY_MS = 5000;

/** Whether an error is irpd's or the agent's "no" (authoritative) rather than a failure to answer. */
function isRefusal(e: unknown): boolean {
  return e instanceof ApiError && [400, 404, 409, 422].includes(e.status);
}

export function describeChange(
  c: ModuleChange,
  before?: { period_ns: number; priority: number; enabled: boolean },
): string[] {
  const out: string[] = [];
  if (c.period_ns != null) out.push(`period ${before ? formatNs(before.period_ns) : "?"} → ${formatNs(c.period_ns)}`);
  if (c.priority != null) out.push(`priority ${before ? before.priority : "?"} → ${c.priority}`);
  if (c.enabled != null) out.push(c.enabled ? "enable" : "disable");
  return out;
}

export class ChangePanel {
  readonly element: HTMLElement;
  private check: Check | null = null;
  private dry: Dry | null = null;
  private timer: ReturnType<typeof setTimeout> | null = null;
  private seq = 0;
  private busy = false;
  private previewKey: string | null = null;
  private limits: Limits = DEFAULT_LIMITS;
  private limitsKnown = false;

  private summary = h("div", { class: "ops-change-summary", "data-testid": "change-summary" });
  private issuesList = h("ul", { class: "ops-issues", "data-testid": "validation" });
  private load = h("div", { class: "ops-load", "data-testid": "utilization" });
  private dryLine = h("div", { class: "ops-dry", "data-testid": "dry-run" });
  private applyBtn = h("button", { class: "primary", "data-testid": "apply", disabled: true }, "Apply…");
  private discardBtn = h("button", { "data-testid": "discard", disabled: true }, "Discard edits");
  private preview = h("div", { class: "ops-preview", "data-testid": "preview", hidden: true });
  private lastIssuesKey = "";

  constructor(
    private readonly ctx: AppContext,
    private readonly table: ModuleTable,
    private readonly onReport: (title: string, r: SwapReport) => void,
  ) {
    this.element = h(
      "section",
      { class: "panel ops-panel ops-changes", "data-testid": "changes" },
      h("h3", {}, "Pending changes"),
      this.summary,
      this.issuesList,
      this.load,
      this.dryLine,
      h("div", { class: "ops-actions" }, this.applyBtn, this.discardBtn),
      this.preview,
    );
    this.applyBtn.addEventListener("click", () => void this.openPreview());
    this.discardBtn.addEventListener("click", () => {
      this.closePreview();
      this.table.discard();
    });
  }

  /** Sets irpd's minimum basic period (status.min_basic_period_ns); irpd's default until known. */
  setMinBasic(ns: number | undefined): void {
    if (ns && ns > 0) {
      this.limits = { ...DEFAULT_LIMITS, minBasicNs: ns };
      this.limitsKnown = true;
    }
  }

  /** Checks the edits again (on every edit and every refresh of the figures). */
  refresh(): void {
    const check = checkEdits(this.table.current, this.table.edits, this.limits);
    this.check = check;
    const key = JSON.stringify(check.changes);
    this.table.mark(check.issues);
    const any = this.table.edits.size > 0;
    this.discardBtn.disabled = !any || this.busy;

    if (this.previewKey !== null && this.previewKey !== key) this.closePreview();

    // summary
    if (!any)
      setText(
        this.summary,
        "No pending changes. Edit a period, a priority or enabled in the table; they are checked as you type.",
      );
    else if (!check.changes.length) setText(this.summary, "The edits equal what runs now: nothing to apply.");
    else
      setText(
        this.summary,
        `${check.changes.length} module${check.changes.length === 1 ? "" : "s"} to change — basic period ${formatNs(check.basicNs)}, macro period ${formatNs(check.macroNs)}` +
          (check.slots !== null && Number.isFinite(check.slots) ? ` (${check.slots} slots)` : "") +
          (this.limitsKnown
            ? ""
            : ` · minimum basic period assumed ${formatNs(this.limits.minBasicNs)} (irpd's default)`),
      );

    // client-side issues (only the ones about the edits when nothing is edited would be noise)
    const shown = any ? distinctMessages(check.issues) : [];
    const issuesKey = JSON.stringify(shown);
    if (issuesKey !== this.lastIssuesKey) {
      this.lastIssuesKey = issuesKey;
      this.issuesList.replaceChildren(
        ...shown.map((i) =>
          h(
            "li",
            { class: i.level === "error" ? "bad" : i.level === "warning" ? "warn" : "", "data-level": i.level },
            `${i.level}: ${i.message}`,
          ),
        ),
      );
    }

    // utilization per executor, now and with the edits
    this.load.hidden = !any;
    if (any) {
      this.load.replaceChildren(
        h("span", { class: "ops-sub" }, "estimated utilization (Σ exec p99 / period): "),
        ...check.load.map((l) =>
          h(
            "span",
            { class: "ops-load-item", "data-executor": l.executor },
            `${l.executor} `,
            h(
              "span",
              { class: "ops-bar small" },
              h("span", {
                class: `ops-bar-fill ${l.level === "error" ? "bad" : l.level === "warning" ? "warn" : ""}`,
                style: `width:${Math.min(100, l.fraction * 100).toFixed(1)}%`,
              }),
            ),
            h(
              "span",
              { class: `num ${l.level === "error" ? "bad" : l.level === "warning" ? "warn" : ""}` },
              ` ${formatPercent(l.fraction)}`,
            ),
          ),
        ),
      );
    }

    // the dry run: when the changes are complete and differ from the last one asked
    if (!check.changes.length || !check.complete) {
      if (this.timer) clearTimeout(this.timer);
      this.timer = null;
      this.dry = null;
      this.seq++;
    } else if (
      !this.dry ||
      this.dry.key !== key ||
      (this.dry.state === "failed" && Date.now() - (this.dry.at ?? 0) > RETRY_MS)
    ) {
      // new changes, or a dry run that failed to get an answer a while ago: ask (again)
      this.dry = { key, state: "pending" };
      if (this.timer) clearTimeout(this.timer);
      this.timer = setTimeout(() => void this.dryRun(check.changes, key), DEBOUNCE_MS);
    }
    this.showDry(check, key);
  }

  stop(): void {
    if (this.timer) clearTimeout(this.timer);
    this.seq++;
  }

  private showDry(check: Check, key: string): void {
    const d = this.dry && this.dry.key === key ? this.dry : null;
    let text = "";
    let cls = "ops-dry";
    if (!this.table.edits.size) text = "";
    else if (!check.complete) {
      text = "Fix the fields marked in red; the server checks the changes once they parse.";
      cls += " bad";
    } else if (!check.changes.length) text = "";
    else if (!d || d.state === "pending") text = "Server check (dry run): checking…";
    else if (d.state === "ok") {
      const r = d.report;
      text = `Server check (dry run): accepted — utilization of the busiest executor ${formatPercent(r.utilization)}${r.warnings.length ? ` · ${r.warnings.join(" · ")}` : ""}`;
      cls += r.warnings.length ? " warn" : " good";
    } else if (d.state === "refused") {
      text = `Server check (dry run): refused — ${d.message}`;
      cls += " bad";
    } else {
      text = `Server check (dry run) failed: ${d.message} — asking again every ${RETRY_MS / 1000} s`;
      cls += " bad";
    }
    setClass(this.dryLine, cls);
    if (this.dryLine.dataset.text !== text) {
      this.dryLine.dataset.text = text;
      this.dryLine.replaceChildren(text);
      if (d?.state === "failed") {
        const retry = h("button", { class: "small", "data-testid": "dry-run-retry" }, "retry");
        retry.addEventListener("click", () => {
          this.dry = null;
          this.refresh();
        });
        this.dryLine.append(" ", retry);
      }
    }
    dataState(this.dryLine, d?.state ?? "none");
    this.applyBtn.disabled = this.busy || d?.state !== "ok";
    this.applyBtn.title =
      d?.state === "ok"
        ? "show the new slot table, then confirm"
        : "available once the server accepted the changes (dry run)";
  }

  private async ask(changes: ModuleChange[], dryRun: boolean): Promise<ChangesReport> {
    return unwrap(await this.ctx.api.POST("/api/v1/modules/changes", { body: { changes, dry_run: dryRun } }));
  }

  private async dryRun(changes: ModuleChange[], key: string): Promise<void> {
    const seq = ++this.seq;
    try {
      const report = await this.ask(changes, true);
      if (seq !== this.seq) return;
      this.dry = { key, state: "ok", report };
    } catch (e) {
      if (seq !== this.seq) return;
      this.dry = {
        key,
        state: isRefusal(e) ? "refused" : "failed",
        message: e instanceof ApiError && isRefusal(e) ? e.message : errorText(e),
        at: Date.now(),
      };
    }
    if (this.check) this.showDry(this.check, JSON.stringify(this.check.changes));
  }

  private closePreview(): void {
    this.previewKey = null;
    this.preview.hidden = true;
    this.preview.replaceChildren();
  }

  private async openPreview(): Promise<void> {
    const check = this.check;
    if (!check || !check.changes.length) return;
    const changes = check.changes;
    const key = JSON.stringify(changes);
    this.busy = true;
    this.applyBtn.disabled = true;
    this.preview.hidden = false;
    this.preview.replaceChildren(h("div", { class: "ops-sub" }, "checking the changes again…"));
    this.previewKey = key;
    let report: ChangesReport;
    try {
      report = await this.ask(changes, true);
      this.dry = { key, state: "ok", report };
    } catch (e) {
      this.busy = false;
      this.dry = { key, state: isRefusal(e) ? "refused" : "failed", message: errorText(e) };
      this.closePreview();
      this.refresh();
      return;
    }
    this.busy = false;
    if (this.previewKey !== key) return;
    this.renderPreview(changes, report);
    this.showDry(check, key);
  }

  private renderPreview(changes: ModuleChange[], report: ChangesReport): void {
    const before = buildSlotTable(report.before as unknown as Schedule);
    const after = buildSlotTable(report.after as unknown as Schedule);
    const changed = changedSlots(before, after);
    const mods = new Set(changes.map((c) => c.name));
    const confirm = h("button", { class: "primary danger", "data-testid": "confirm" }, "Confirm: hot swap now");
    const cancel = h("button", { "data-testid": "cancel" }, "Cancel");
    const error = h("div", { class: "ops-error", "data-testid": "apply-error", hidden: true });
    const current = new Map(this.table.current.map((m) => [m.name, m]));
    this.preview.replaceChildren(
      h("h4", {}, "Review the change"),
      h(
        "table",
        { class: "ops-grid ops-dense", "data-testid": "preview-changes" },
        h("thead", {}, h("tr", {}, h("th", {}, "module"), h("th", {}, "change"))),
        h(
          "tbody",
          {},
          ...changes.map((c) =>
            h(
              "tr",
              {},
              h("td", { class: "mono" }, c.name),
              h("td", {}, describeChange(c, current.get(c.name)).join(", ")),
            ),
          ),
        ),
      ),
      h(
        "div",
        { class: "ops-sub" },
        `estimated utilization of the busiest executor after the change: ${formatPercent(report.utilization)}`,
        report.warnings.length
          ? h("ul", { class: "ops-issues" }, ...report.warnings.map((w) => h("li", { class: "warn" }, `warning: ${w}`)))
          : null,
      ),
      h(
        "div",
        { class: "ops-side-by-side" },
        h("div", {}, h("h5", {}, "now"), renderSlotTable(before, { testid: "preview-before" })),
        h(
          "div",
          {},
          h(
            "h5",
            {},
            "after the change",
            changed.size ? h("span", { class: "ops-sub" }, ` — ${changed.size} slot(s) differ`) : null,
          ),
          renderSlotTable(after, { testid: "preview-after", changed, changedModules: mods }),
        ),
      ),
      h("div", { class: "ops-actions" }, confirm, cancel),
      error,
    );
    cancel.addEventListener("click", () => {
      this.closePreview();
      this.refresh();
    });
    confirm.addEventListener("click", async () => {
      confirm.disabled = true;
      cancel.disabled = true;
      this.busy = true;
      setText(confirm, "Swapping…");
      try {
        const done = await this.ask(changes, false);
        this.closePreview();
        this.busy = false;
        if (done.report)
          this.onReport(`Module changes applied (${changes.map((c) => c.name).join(", ")})`, done.report);
        this.ctx.notify(`module changes applied: ${changes.map((c) => c.name).join(", ")}`);
        this.table.discard();
      } catch (e) {
        this.busy = false;
        error.hidden = false;
        setText(error, `not applied: ${errorText(e)}`);
        setText(confirm, "Confirm: hot swap now");
        confirm.disabled = false;
        cancel.disabled = false;
        this.ctx.notify(`module changes not applied: ${errorText(e)}`, "error");
      }
    });
  }
}

function dataState(e: HTMLElement, state: string): void {
  if (e.dataset.state !== state) e.dataset.state = state;
}
