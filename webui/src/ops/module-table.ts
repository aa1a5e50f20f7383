// module-table.ts -- the modules of the running set, one row each, refreshed in place: figures
// update every poll while the operator's edits (period, priority, enabled) stay as typed.
import { h, setClass, setText } from "./dom";
import type { ModuleInfo } from "./types";
import { formatCount, formatNs, parsePeriod, periodText } from "./units";
import type { Edit, Issue } from "./validate";

interface Row {
  tr: HTMLTableRowElement;
  cells: Record<string, HTMLElement>;
  period?: HTMLInputElement;
  priority?: HTMLInputElement;
  enabled?: HTMLInputElement;
  was: HTMLElement;
}

const COLUMNS: [key: string, label: string, cls: string, title?: string][] = [
  ["name", "name", "mono"],
  ["executor", "executor", "mono"],
  ["type", "type", ""],
  ["operation", "operation", ""],
  ["period", "period", "num"],
  ["deadline", "deadline", "num"],
  ["priority", "priority", "num", "lowest value runs first"],
  ["enabled", "enabled", "center"],
  ["state", "state", ""],
  ["runs", "runs", "num"],
  ["jitter", "jitter p99", "num", "start time minus due time, 99th percentile since irpd started"],
  ["execP99", "exec p99", "num", "execution time, 99th percentile"],
  ["execMax", "exec max", "num", "longest execution time"],
  ["overruns", "overruns", "num"],
  ["missed", "missed", "num"],
  ["errors", "errors", "num"],
];

function stateClass(m: ModuleInfo): string {
  if (!m.enabled || m.state === "disabled") return "state muted";
  switch (m.state) {
    case "running":
      return "state good";
    case "exited":
    case "stopped":
      return "state bad";
    case "skipped":
    case "loaded":
      return "state warn";
    default:
      return "state";
  }
}

export class ModuleTable {
  readonly element: HTMLElement;
  readonly edits = new Map<string, Edit>();
  private body: HTMLTableSectionElement;
  private rows = new Map<string, Row>();
  private modules: ModuleInfo[] = [];

  constructor(
    private readonly editable: boolean,
    private readonly onEdit: () => void,
  ) {
    this.body = h("tbody", {});
    this.element = h(
      "table",
      { class: "ops-grid ops-dense ops-modules", "data-testid": "module-table" },
      h(
        "thead",
        {},
        h("tr", {}, ...COLUMNS.map(([, label, cls, title]) => h("th", { class: cls, title: title ?? null }, label))),
      ),
      this.body,
    );
  }

  /** The last modules shown. */
  get current(): ModuleInfo[] {
    return this.modules;
  }

  /** Shows `modules`: figures replaced, edited inputs left as they are. */
  update(modules: ModuleInfo[]): void {
    this.modules = modules;
    const names = modules.map((m) => m.name);
    if (names.join("\u0000") !== [...this.rows.keys()].join("\u0000")) {
      this.rows.clear();
      this.body.replaceChildren(...modules.map((m) => this.makeRow(m).tr));
    }
    for (const m of modules) this.fill(this.rows.get(m.name)!, m);
  }

  /** Marks inputs with the issues that name them (errors win over warnings). */
  mark(issues: Issue[]): void {
    for (const [name, row] of this.rows) {
      for (const field of ["period", "priority", "enabled"] as const) {
        const input = row[field];
        if (!input) continue;
        const mine = issues.filter((i) => i.module === name && i.field === field);
        const level = mine.some((i) => i.level === "error")
          ? "invalid"
          : mine.some((i) => i.level === "warning")
            ? "warning"
            : "";
        const dirty = this.edits.get(name)?.[field] !== undefined;
        setClass(input, `ops-edit${dirty ? " dirty" : ""}${level ? ` ${level}` : ""}`);
        input.title = mine.map((i) => i.message).join("\n");
        input.setAttribute("aria-invalid", String(level === "invalid"));
      }
    }
  }

  /** Forgets every edit and shows what runs again. */
  discard(): void {
    this.edits.clear();
    for (const m of this.modules) {
      const row = this.rows.get(m.name);
      if (row) this.fill(row, m, true);
    }
    this.onEdit();
  }

  private makeRow(m: ModuleInfo): Row {
    const cells: Record<string, HTMLElement> = {};
    for (const [key, , cls] of COLUMNS) cells[key] = h("td", { class: cls, "data-col": key });
    const row: Row = {
      tr: h("tr", { "data-testid": `module-row-${m.name}`, "data-module": m.name }),
      cells,
      was: h("div", { class: "ops-was" }),
    };
    setText(cells.name, m.name);
    if (this.editable) {
      if (m.operationtype === "periodic") {
        row.period = h("input", {
          type: "text",
          class: "ops-edit",
          size: 8,
          spellcheck: "false",
          autocomplete: "off",
          "data-testid": `edit-period-${m.name}`,
          "aria-label": `period of ${m.name}`,
          placeholder: "e.g. 10ms",
        });
        row.period.addEventListener("input", () => this.edited(m.name, "period", row.period!.value));
        cells.period.append(row.period, row.was);
      }
      row.priority = h("input", {
        type: "text",
        inputmode: "numeric",
        class: "ops-edit",
        size: 4,
        autocomplete: "off",
        "data-testid": `edit-priority-${m.name}`,
        "aria-label": `priority of ${m.name}`,
      });
      row.priority.addEventListener("input", () => this.edited(m.name, "priority", row.priority!.value));
      cells.priority.append(row.priority);
      row.enabled = h("input", {
        type: "checkbox",
        class: "ops-edit",
        "data-testid": `edit-enabled-${m.name}`,
        "aria-label": `${m.name} enabled`,
      });
      row.enabled.addEventListener("change", () => this.edited(m.name, "enabled", row.enabled!.checked));
      cells.enabled.append(row.enabled);
    }
    // rows are rebuilt when the set's modules change: pending edits come back into their inputs
    const e = this.edits.get(m.name);
    if (row.period && e?.period !== undefined) row.period.value = e.period;
    if (row.priority && e?.priority !== undefined) row.priority.value = e.priority;
    if (row.enabled && e?.enabled !== undefined) row.enabled.checked = e.enabled;
    for (const [key] of COLUMNS) row.tr.append(cells[key]);
    this.rows.set(m.name, row);
    return row;
  }

  private edited(name: string, field: "period" | "priority" | "enabled", value: string | boolean): void {
    const m = this.modules.find((x) => x.name === name);
    if (!m) return;
    const e: Edit = { ...this.edits.get(name) };
    const same =
      field === "period"
        ? (() => {
            const p = parsePeriod(String(value));
            return p.ok && p.ns === m.period_ns;
          })()
        : field === "priority"
          ? String(value).trim() === String(m.priority)
          : value === m.enabled;
    if (same) delete e[field];
    else if (field === "enabled") e.enabled = value as boolean;
    else e[field] = String(value);
    if (Object.keys(e).length) this.edits.set(name, e);
    else this.edits.delete(name);
    const row = this.rows.get(name);
    if (row) this.fill(row, m);
    this.onEdit();
  }

  private fill(row: Row, m: ModuleInfo, force = false): void {
    const c = row.cells;
    const periodic = m.operationtype === "periodic";
    setText(c.executor, m.executor);
    setText(c.type, m.moduletype);
    setText(c.operation, m.operationtype);
    setText(c.deadline, m.deadline_ns ? formatNs(m.deadline_ns) : "–");
    const measured = m.runs > 0;
    setText(c.runs, formatCount(m.runs));
    setText(c.jitter, measured && periodic ? formatNs(m.jitter_ns.p99, 3) : "–");
    setText(c.execP99, measured ? formatNs(m.exec_ns.p99, 3) : "–");
    setText(c.execMax, measured ? formatNs(m.exec_ns.max, 3) : "–");
    setText(c.overruns, formatCount(m.overruns));
    setText(c.missed, formatCount(m.missed));
    setText(c.errors, formatCount(m.errors));
    setClass(c.overruns, `num ${m.overruns ? "warn" : ""}`);
    setClass(c.missed, `num ${m.missed ? "warn" : ""}`);
    setClass(c.errors, `num ${m.errors ? "bad" : ""}`);
    const state = m.enabled ? m.state : m.state === "disabled" ? "disabled" : `${m.state} (disabled)`;
    setText(c.state, state);
    setClass(c.state, stateClass(m));
    row.tr.title = m.last_error ? `last error: ${m.last_error}` : "";
    const e = this.edits.get(m.name);

    if (row.period) {
      if (force || (e?.period === undefined && document.activeElement !== row.period))
        row.period.value = periodText(m.period_ns);
      setText(row.was, e?.period !== undefined ? `now ${formatNs(m.period_ns)}` : "");
    } else setText(c.period, periodic ? formatNs(m.period_ns) : "–");
    if (row.priority) {
      if (force || (e?.priority === undefined && document.activeElement !== row.priority))
        row.priority.value = String(m.priority);
    } else setText(c.priority, String(m.priority));
    if (row.enabled) {
      if (force || e?.enabled === undefined) row.enabled.checked = m.enabled;
    } else setText(c.enabled, m.enabled ? "yes" : "no");
  }
}
