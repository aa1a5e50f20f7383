// swap-report-view.ts -- irpd's report of a hot swap (or of a restart onto a set), as people read
// it: which modules were kept, started, stopped, replaced (started anew under the same name), the
// cycle the new table took over at, the periods missed, how long it took, the shared variables it
// added, removed and moved, and for a restart the measured downtime.
import { reportMode, variableDiff } from "./activation";
import { h } from "./dom";
import type { SwapReport } from "./types";
import { formatCount, formatNs } from "./units";
import { renderVariableDiff } from "./variable-diff-view";

export function renderSwapReport(title: string, r: SwapReport, at: Date = new Date()): HTMLElement {
  const list = (names: string[] | undefined) => (names && names.length ? names.join(", ") : "—");
  const missed = r.missed_periods ?? null;
  const { mode, downtimeNs } = reportMode(r);
  const row = (label: string, value: string, cls = "", testid?: string) =>
    h("tr", {}, h("th", {}, label), h("td", { class: cls, "data-testid": testid ?? null }, value));
  const vars =
    mode === "restart" && !r.variables
      ? h(
          "div",
          { "data-testid": "report-variables" },
          h(
            "div",
            { "data-testid": "report-variables-summary" },
            "shared variables laid out afresh by the restart: every one started at zero",
          ),
        )
      : renderVariableDiff(variableDiff(r.variables), "report-variables");
  return h(
    "div",
    { class: "ops-report" },
    h("h4", {}, title, h("span", { class: "ops-sub" }, ` at ${at.toLocaleTimeString()}`)),
    h(
      "table",
      { class: "ops-kv" },
      row("set", `${r.set ?? "–"}${r.set_id ? ` (id ${r.set_id})` : ""}`, "mono wrap"),
      row("generation", r.generation != null ? String(r.generation) : "–", "num"),
      mode ? row("how", mode === "restart" ? "restart of irpd" : "hot swap", "", "report-mode") : null,
      mode === "restart"
        ? row("downtime", downtimeNs !== null ? formatNs(downtimeNs) : "not measured", "num", "report-downtime")
        : null,
      row("kept", list(r.kept), "mono", "report-kept"),
      row("started", list(r.started), "mono", "report-started"),
      row("stopped", list(r.stopped), "mono", "report-stopped"),
      row("replaced", list(r.replaced), "mono", "report-replaced"),
      row("swap cycle", r.swap_cycle != null ? formatCount(r.swap_cycle) : "–", "num", "report-swap-cycle"),
      row(
        "missed periods",
        missed != null ? String(missed) : "–",
        `num state ${missed === 0 ? "good" : missed ? "bad" : ""}`,
        "report-missed",
      ),
      row("request to swap", formatNs(r.request_to_swap_ns ?? null), "num", "report-request-to-swap"),
      row("total", formatNs(r.total_ns ?? null), "num"),
    ),
    vars,
  );
}
