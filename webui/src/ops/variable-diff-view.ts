// variable-diff-view.ts -- the shared variables a set's layout changes against the running one
// (a check's or a swap report's `variables`): added, removed, moved with their types from -> to
// and why their value cannot be kept (such a set needs the managed restart), converted with their types from -> to, and the modules irpd
// loads anew because of the layout; one line when nothing changes.
import type { VariableDiff, VariableRow } from "./activation";
import { h } from "./dom";

/** The shared-variable diff: added, removed, moved (byte offsets from → to), converted (types from → to), and the modules replaced. */
export function renderVariableDiff(d: VariableDiff, testid = "plan-variables"): HTMLElement {
  const sign = { added: "+ added", removed: "− removed", moved: "~ moved", converted: "≈ converted" } as const;
  const detail = (r: VariableRow): string =>
    r.kind === "moved"
      ? `${r.fromType && r.toType ? `${r.fromType} → ${r.toType}` : `${r.from} → ${r.to}`}: not convertible without loss${r.reason ? ` (${r.reason})` : ""}`
      : r.kind === "converted"
        ? `${r.fromType} → ${r.toType}${r.dropped.length ? ` (dropped ${r.dropped.join(", ")})` : ""}`
        : "";
  const notes = [
    d.rows.some((r) => r.kind === "added") ? "added variables start at their initial values (zero in a .glb)" : "",
    d.rows.some((r) => r.kind === "moved") ? "a moved variable's type change needs the managed restart of irpd" : "",
    d.rows.some((r) => r.kind === "converted") ? "converted variables keep their values in their new types" : "",
    d.rows.some((r) => r.kind === "removed") ? "a removed variable's room stays empty until irpd restarts" : "",
  ].filter(Boolean);
  return h(
    "div",
    { class: "ops-vardiff", "data-testid": testid },
    h("div", { class: d.unchanged ? "ops-sub" : "", "data-testid": `${testid}-summary` }, d.summary),
    d.rows.length
      ? h(
          "table",
          { class: "ops-grid ops-dense" },
          h(
            "thead",
            {},
            h("tr", {}, h("th", {}, "change"), h("th", {}, "variable"), h("th", {}, "byte offset or type")),
          ),
          h(
            "tbody",
            {},
            ...d.rows.map((r) =>
              h(
                "tr",
                { class: `vardiff-${r.kind}`, "data-variable": r.path },
                h("td", {}, sign[r.kind]),
                h("td", { class: "mono" }, r.path),
                h("td", { class: "mono" }, detail(r)),
              ),
            ),
          ),
        )
      : null,
    notes.length ? h("div", { class: "ops-sub" }, notes.join("; ")) : null,
    d.replaced.length
      ? h(
          "div",
          { "data-testid": `${testid}-replaced` },
          "replaced because of the layout (loaded anew, not kept): ",
          h("span", { class: "mono" }, d.replaced.join(", ")),
        )
      : null,
    d.layout && !d.unchanged
      ? h("div", { class: "ops-sub mono", title: d.layout }, `layout ${d.layout.slice(0, 12)}…`)
      : null,
  );
}
