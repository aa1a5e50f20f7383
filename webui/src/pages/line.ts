// line.ts -- the Line page: every controller this controller's DDS bridge sees on its domain, with
// its state (green ok, amber warning, red fault or lost), health, set, jitter, alarms and a link to
// its own web UI (a new tab); this controller is marked.  Polled every second; when the bridge is
// off the page says so instead of showing an empty table.
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { errorText, h, poll, setClass, setText } from "../ops/dom";
import { type LineController, type LineView, lineNotice, lineRow, lineSummary } from "../ops/line";

const HEADERS: [string, string][] = [
  ["controller", ""],
  ["state", ""],
  ["health", ""],
  ["set", ""],
  ["jitter p99", "the main dispatcher's wake-up latency (woke − due), 99th percentile over the last 10 s"],
  ["alarms", "active alarms (the most severe one's severity)"],
  ["up", "irpd's uptime"],
  ["last seen", "when its last announcement arrived"],
  ["web UI", ""],
];

/** One controller's row, made once and updated in place (a click on its link is never lost to a redraw). */
class Row {
  readonly tr = h("tr");
  private readonly cells = HEADERS.map(() => h("td"));
  private readonly name = h("span");
  private readonly mark = h("span", { class: "ops-sub", "data-testid": "line-this" }, " (this controller)");
  private href: string | null | undefined = undefined;

  constructor(name: string) {
    this.tr.dataset.testid = `line-row-${name}`;
    this.cells[0].append(this.name, this.mark);
    this.cells[1].dataset.testid = "line-state";
    for (const i of [4, 5, 6]) this.cells[i].className = "num";
    this.tr.append(...this.cells);
  }

  update(c: LineController): void {
    const r = lineRow(c);
    this.tr.dataset.state = r.state;
    setClass(this.tr, r.this ? "active" : "");
    setText(this.name, r.name);
    this.mark.hidden = !r.this;
    setClass(this.cells[1], `state ${r.stateClass}`);
    this.cells[1].title = r.reasons;
    const texts = [r.state, r.health, r.set, r.jitter, r.alarms, r.uptime, r.seen];
    for (const [i, t] of texts.entries()) setText(this.cells[i + 1], t);
    this.cells[3].title = r.setTitle;
    this.cells[5].title = r.alarmsTitle;
    if (r.link !== this.href) {
      this.href = r.link;
      this.cells[8].replaceChildren(
        r.link
          ? h("a", { href: r.link, target: "_blank", rel: "noopener noreferrer", "data-testid": "line-link" }, r.link)
          : h("span", { class: "muted" }, "–"),
      );
    }
  }
}

export const linePage: Page = (root, ctx) => {
  const info = h("span", { class: "ops-sub", "data-testid": "line-info" });
  const notice = h("div", { class: "ops-banner", "data-testid": "line-notice", role: "status", hidden: true });
  const error = h("div", { class: "ops-error", "data-testid": "line-error", hidden: true });
  const body = h("tbody");
  const rows = new Map<string, Row>();
  const table = h(
    "table",
    { class: "ops-grid", "data-testid": "line-table" },
    h("thead", {}, h("tr", {}, ...HEADERS.map(([t, title]) => h("th", { title: title || null }, t)))),
    body,
  );
  const reasons = h("ul", { class: "ops-sub", "data-testid": "line-reasons" });
  const panel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Line", info),
    notice,
    error,
    h("div", { class: "ops-scroll wide" }, table),
    reasons,
  );
  root.append(h("div", { class: "ops-page", "data-testid": "line" }, panel));

  const p = poll(
    async () => {
      const view = unwrap(await ctx.api.GET("/api/v1/line")) as LineView;
      error.hidden = true;
      panel.classList.remove("stale");
      const n = lineNotice(view);
      notice.hidden = !n.text;
      setClass(notice, `ops-banner ${n.level}`);
      setText(notice, n.text);
      table.hidden = view.bridge !== "ok";
      setText(info, view.bridge === "ok" ? ` — ${lineSummary(view)}` : "");
      const seen = new Set<string>();
      for (const c of view.controllers) {
        seen.add(c.name);
        const r = rows.get(c.name) ?? new Row(c.name);
        rows.set(c.name, r);
        r.update(c);
      }
      for (const name of [...rows.keys()]) if (!seen.has(name)) rows.delete(name);
      body.replaceChildren(...view.controllers.map((c) => rows.get(c.name)!.tr));
      reasons.replaceChildren(
        ...view.controllers
          .filter((c) => c.reasons.length)
          .map((c) => h("li", {}, `${c.name}: ${c.reasons.join("; ")}`)),
      );
    },
    1000,
    (e) => {
      error.hidden = false;
      setText(error, `${errorText(e)} — retrying every second; what is shown is stale`);
      panel.classList.add("stale");
    },
  );
  return () => p.stop();
};
