// slot-table-view.ts -- the slot table as the paper's Table 3: one row per basic period (slot)
// with its offset, the modules it runs in priority order, and the macro period it repeats in;
// the sporadic and non-real modules listed after it.
import { h } from "./dom";
import type { SlotTable } from "./timeline";
import { formatNs } from "./units";

export interface SlotTableOptions {
  testid?: string;
  /** slot indices drawn as changed (the change preview) */
  changed?: Set<number>;
  /** modules drawn as changed */
  changedModules?: Set<string>;
  /** called when a slot's number is clicked */
  onSlot?: (slot: number) => void;
  /** the slot drawn as selected */
  selected?: number | null;
}

export function renderSlotTable(t: SlotTable, opt: SlotTableOptions = {}): HTMLElement {
  const cols = Math.max(1, t.columns);
  const head = h(
    "tr",
    {},
    h("th", { class: "num" }, "slot"),
    h("th", { class: "num" }, "offset"),
    h("th", { colspan: cols }, "modules run (in priority order →)"),
    h("th", {}, "macro period"),
  );
  const body = h("tbody", {});
  t.rows.forEach((r, i) => {
    const cells: HTMLElement[] = r.cells.map((c) =>
      h(
        "td",
        {
          class: `slot-mod${opt.changedModules?.has(c.name) ? " changed" : ""}`,
          "data-module": c.name,
          title: `${c.name}: ${c.moduletype}, period ${formatNs(c.period_ns)}, priority ${c.priority}, executor ${c.executor}`,
        },
        c.name,
        c.executor !== "main" ? h("span", { class: "ops-sub" }, `@${c.executor}`) : null,
      ),
    );
    while (cells.length < cols) cells.push(h("td", { class: "slot-empty" }));
    const num = h("td", { class: `num${opt.onSlot ? " clickable" : ""}` }, String(r.index));
    if (opt.onSlot) num.addEventListener("click", () => opt.onSlot!(r.index));
    const tr = h(
      "tr",
      {
        "data-slot": r.index,
        class:
          [opt.changed?.has(i) ? "changed" : "", opt.selected === r.index ? "selected" : ""].join(" ").trim() || null,
      },
      num,
      h("td", { class: "num" }, formatNs(r.offsetNs)),
      ...cells,
    );
    if (i === 0)
      tr.append(
        h(
          "td",
          { rowspan: t.rows.length, class: "slot-macro" },
          `repeat the ${t.slots} basic period${t.slots === 1 ? "" : "s"} every ${formatNs(t.macroNs)}`,
        ),
      );
    body.append(tr);
  });
  const table = h(
    "table",
    { class: "ops-grid ops-slot-table", "data-testid": opt.testid ?? null },
    h("thead", {}, head),
    body,
  );
  const wrap = h(
    "div",
    { class: "ops-slot-wrap" },
    h(
      "div",
      { class: "ops-sub" },
      `basic period ${formatNs(t.basicNs)} (GCD) · macro period ${formatNs(t.macroNs)} (LCM) · ${t.slots} slot${t.slots === 1 ? "" : "s"}`,
    ),
    table,
  );
  if (t.rows.length < t.slots)
    wrap.append(h("div", { class: "ops-sub" }, `first ${t.rows.length} of ${t.slots} slots shown`));
  if (t.outside.length)
    wrap.append(
      h(
        "div",
        { class: "ops-outside", "data-testid": opt.testid ? `${opt.testid}-outside` : null },
        h("span", { class: "ops-sub" }, "outside the table: "),
        ...t.outside.map((m) =>
          h(
            "span",
            { class: `ops-chip ${m.operationtype === "sporadic" ? "sporadic" : "nonreal"}`, "data-module": m.name },
            m.name,
            h(
              "span",
              { class: "ops-sub" },
              m.operationtype === "sporadic"
                ? ` sporadic ${m.moduletype}, deadline ${formatNs(m.deadline_ns)}, priority ${m.priority}, checked every basic period`
                : ` non-real ${m.moduletype}, runs in the time left over`,
            ),
          ),
        ),
      ),
    );
  return wrap;
}
