// modules.ts -- the modules page: every module of the running set with its live figures (every
// second); for operators, inline edits of period, priority and enabled, checked as typed and by a
// dry run, applied in one hot swap after a preview; for admins, set uploads; the set history
// with activate (after irpd's check against what runs now: slot tables, shared variables, restart)
// and roll back.
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { ChangePanel } from "../ops/change-panel";
import { errorText, h, poll, setText } from "../ops/dom";
import { ModuleTable } from "../ops/module-table";
import { SetHistory } from "../ops/set-history";
import { renderSwapReport } from "../ops/swap-report-view";
import type { ModuleInfo, Status, SwapReport } from "../ops/types";
import { formatNs } from "../ops/units";
import { UploadPanel } from "../ops/upload-panel";

export const modulesPage: Page = (root, ctx) => {
  const editable = ctx.can("operator");
  let panel: ChangePanel | null = null;
  const table = new ModuleTable(editable, () => panel?.refresh());

  const reportArea = h("section", {
    class: "panel ops-panel ops-report-area",
    "data-testid": "swap-report",
    hidden: true,
  });
  const showReport = (title: string, r: SwapReport) => {
    reportArea.hidden = false;
    const close = h("button", { class: "link small ops-close", "aria-label": "close" }, "×");
    close.addEventListener("click", () => (reportArea.hidden = true));
    reportArea.replaceChildren(close, renderSwapReport(title, r));
    modulesPoll.now();
    reportArea.scrollIntoView?.({ block: "nearest" });
  };

  if (editable) panel = new ChangePanel(ctx, table, showReport);
  const sets = new SetHistory(ctx, showReport);
  const upload = ctx.can("admin")
    ? new UploadPanel(
        ctx,
        () => void sets.refresh(),
        (id, onClose) => sets.reviewOf(id, onClose),
      )
    : null;

  const info = h("span", { class: "ops-sub", "data-testid": "modules-info" });
  const error = h("div", { class: "ops-error", "data-testid": "modules-error", hidden: true });
  const tablePanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Modules", info),
    error,
    h("div", { class: "ops-scroll wide" }, table.element),
    editable ? null : h("div", { class: "ops-sub" }, `signed in as ${ctx.session.role}: read only`),
  );

  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "modules" },
      tablePanel,
      panel?.element ?? null,
      reportArea,
      upload?.element ?? null,
      sets.element,
    ),
  );

  const modulesPoll = poll(
    async () => {
      const [mods, status] = await Promise.all([
        ctx.api.GET("/api/v1/modules").then((r) => unwrap(r) as unknown as ModuleInfo[]),
        ctx.api.GET("/api/v1/status").then((r) => unwrap(r) as unknown as Status),
      ]);
      error.hidden = true;
      tablePanel.classList.remove("stale");
      table.update(mods);
      panel?.setMinBasic(status.min_basic_period_ns ?? undefined);
      setText(
        info,
        ` — ${mods.length} in ${status.set ?? "?"} · basic period ${formatNs(status.basic_period_ns)} · macro period ${formatNs(status.macro_period_ns)}` +
          (status.min_basic_period_ns ? ` · minimum basic period ${formatNs(status.min_basic_period_ns)}` : ""),
      );
      panel?.refresh();
    },
    1000,
    (e) => {
      error.hidden = false;
      setText(error, `${errorText(e)} — retrying every second; the figures shown are stale`);
      tablePanel.classList.add("stale");
    },
  );
  const setsPoll = poll(() => sets.refresh(), 5000);

  return () => {
    modulesPoll.stop();
    setsPoll.stop();
    panel?.stop();
  };
};
