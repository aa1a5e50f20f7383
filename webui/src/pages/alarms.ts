// alarms.ts -- the Alarms page: what needs attention (live from the alarm push) with Acknowledge,
// Shelve and Unshelve for operators, and the history (GET /alarms/history) with its filters,
// paging and the CSV export of what the filters select.
import "../ops/ops.css";
import { ApiError, detailOf, unwrap } from "../api/client";
import type { Page } from "../app/context";
import {
  type AlarmView,
  bannerOf,
  csvPath,
  type HistoryQuery,
  historyQuery,
  pageText,
  SEVERITIES,
  STATES,
  sortedAlarms,
  stateLevel,
  stateText,
} from "../ops/alarms";
import { errorText, h, setClass, setText } from "../ops/dom";
import type { AlarmPublic, AlarmTransition } from "../ops/types";
import { formatTime } from "../ops/units";

const PAGE = 50;
const SHELVE_MINUTES = 60;

export const alarmsPage: Page = (root, ctx) => {
  const operator = ctx.can("operator");
  const info = h("span", { class: "ops-sub", "data-testid": "alarm-counts" }, "");
  const listError = h("div", { class: "ops-error", "data-testid": "alarm-error", hidden: true, role: "alert" });
  const segmentInfo = h("div", { class: "ops-sub", "data-testid": "alarm-segment" }, "");
  const body = h("tbody", {});
  const ackAll = h("button", { "data-testid": "ack-all" }, "Acknowledge all");
  const listPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Alarms", info),
    operator ? h("div", { class: "ops-actions" }, ackAll) : null,
    listError,
    h(
      "div",
      { class: "ops-scroll" },
      h(
        "table",
        { class: "ops-grid ops-dense", "data-testid": "alarm-list" },
        h(
          "thead",
          {},
          h(
            "tr",
            {},
            h("th", {}, "severity"),
            h("th", {}, "alarm"),
            h("th", {}, "text"),
            h("th", {}, "state"),
            h("th", {}, "raised"),
            h("th", {}, "acknowledged"),
            operator ? h("th", {}, "") : null,
          ),
        ),
        body,
      ),
    ),
    segmentInfo,
  );

  // ---- acting on an alarm ------------------------------------------------------------------------
  const act = async (what: string, call: () => Promise<unknown>) => {
    listError.hidden = true;
    try {
      await call();
      ctx.notify(what);
    } catch (e) {
      listError.hidden = false;
      setText(listError, `${what}: ${errorText(e)}`);
    }
  };
  const keyed = (key: string) => ({ params: { path: { key } } });
  ackAll.addEventListener("click", () =>
    act("acknowledged every alarm", async () => unwrap(await ctx.api.POST("/api/v1/alarms/ack", {}))),
  );
  // the alarm whose shelve form is open, and the form (kept across the pushes' re-renders)
  let shelving: { key: string; form: HTMLElement } | null = null;

  const shelveForm = (a: AlarmPublic): HTMLElement => {
    const minutes = h("input", {
      type: "number",
      min: 1,
      max: 10080,
      value: SHELVE_MINUTES,
      class: "ops-edit",
      size: 4,
      "data-testid": "shelve-minutes",
    });
    const reason = h("input", {
      type: "text",
      class: "ops-edit",
      placeholder: "why (for the history)",
      maxlength: 200,
      "data-testid": "shelve-reason",
    });
    const ok = h("button", { class: "small primary", "data-testid": "shelve-confirm" }, "Shelve");
    const cancel = h("button", { class: "small", "data-testid": "shelve-cancel" }, "Cancel");
    const check = () => {
      ok.disabled = !reason.value.trim() || !(Number(minutes.value) > 0);
    };
    minutes.addEventListener("input", check);
    reason.addEventListener("input", check);
    check();
    cancel.addEventListener("click", () => {
      shelving = null;
      render();
    });
    ok.addEventListener("click", () =>
      act(`shelved ${a.key}`, async () => {
        unwrap(
          await ctx.api.POST("/api/v1/alarms/{key}/shelve", {
            ...keyed(a.key),
            body: { minutes: Number(minutes.value), reason: reason.value.trim() },
          }),
        );
        shelving = null;
      }),
    );
    return h("span", { class: "ops-row-actions" }, minutes, " min ", reason, ok, cancel);
  };

  const actions = (a: AlarmPublic): HTMLElement => {
    if (shelving?.key === a.key) return shelving.form;
    const out = h("span", { class: "ops-row-actions" });
    if (!a.acknowledged) {
      const b = h("button", { class: "small primary", "data-testid": `ack-${a.key}` }, "Acknowledge");
      b.addEventListener("click", () =>
        act(`acknowledged ${a.key}`, async () => unwrap(await ctx.api.POST("/api/v1/alarms/{key}/ack", keyed(a.key)))),
      );
      out.append(b);
    }
    if (a.state === "shelved") {
      const b = h("button", { class: "small", "data-testid": `unshelve-${a.key}` }, "Unshelve");
      b.addEventListener("click", () =>
        act(`unshelved ${a.key}`, async () =>
          unwrap(await ctx.api.POST("/api/v1/alarms/{key}/unshelve", keyed(a.key))),
        ),
      );
      out.append(b);
    } else {
      const b = h("button", { class: "small", "data-testid": `shelve-${a.key}` }, "Shelve…");
      b.addEventListener("click", () => {
        shelving = { key: a.key, form: shelveForm(a) };
        render();
      });
      out.append(b);
    }
    return out;
  };

  const row = (a: AlarmPublic): HTMLElement => {
    const state =
      a.state === "shelved"
        ? `shelved until ${formatTime(a.shelved_until ?? "")} by ${a.shelved_by?.name ?? "?"}: ${a.shelve_reason ?? ""}`
        : stateText(a.state);
    const flags = a.flags.length ? ` [${a.flags.join(", ")}]` : "";
    return h(
      "tr",
      { "data-testid": `alarm-${a.key}`, "data-key": a.key, "data-state": a.state },
      h("td", { class: `state ${a.severity === "high" || a.severity === "critical" ? "bad" : "warn"}` }, a.severity),
      h(
        "td",
        { class: "mono nowrap" },
        a.key,
        a.origin === "system" ? h("span", { class: "ops-sub" }, " (system)") : null,
      ),
      h(
        "td",
        { class: "wrap" },
        a.text,
        a.detail ? h("div", { class: "ops-sub" }, `${a.detail}${a.value ? ` (${a.value})` : ""}${flags}`) : null,
      ),
      h("td", { class: `state ${stateLevel(a.state)}`, "data-testid": `state-${a.key}` }, state),
      h("td", { class: "mono nowrap", title: a.raised ?? "" }, a.raised ? formatTime(a.raised) : "–"),
      h(
        "td",
        { class: "nowrap" },
        a.acknowledged_by ? `${a.acknowledged_by.name}, ${formatTime(a.acknowledged_at ?? "")}` : "–",
      ),
      operator ? h("td", { class: "nowrap" }, actions(a)) : null,
    );
  };

  let view: AlarmView | null = null;
  const render = () => {
    if (!view) return;
    const alarms = sortedAlarms(view.alarms.values());
    body.replaceChildren(
      ...(alarms.length
        ? alarms.map(row)
        : [h("tr", {}, h("td", { colspan: operator ? 7 : 6, class: "muted" }, "no alarm needs attention"))]),
    );
    ackAll.disabled = !alarms.some((a) => !a.acknowledged);
    const s = view.segment;
    const parts = s
      ? [
          s.error ? `irpd's alarm segment not read: ${s.error}` : `segment ${s.name}`,
          s.lost ? `${s.lost} records lost (reconciled)` : "",
          s.suppressed ? `${s.suppressed} transitions of floods not recorded one by one` : "",
        ]
      : [];
    setText(segmentInfo, parts.filter(Boolean).join(" · "));
  };

  // ---- history -----------------------------------------------------------------------------------
  const input = (testid: string, type = "text") => h("input", { type, class: "ops-edit", "data-testid": testid });
  const select = (testid: string, values: string[], label: (v: string) => string) =>
    h(
      "select",
      { class: "ops-edit", "data-testid": testid },
      h("option", { value: "" }, "any"),
      values.map((v) => h("option", { value: v }, label(v))),
    );
  const form = {
    since: input("history-since", "datetime-local"),
    until: input("history-until", "datetime-local"),
    module: input("history-module"),
    severity: select("history-severity", SEVERITIES, (v) => v),
    state: select("history-state", STATES, stateText),
  };
  const apply = h("button", { "data-testid": "history-apply" }, "Apply");
  const csv = h("button", { "data-testid": "history-csv" }, "Export CSV");
  const newer = h("button", { class: "small", "data-testid": "history-newer" }, "‹ newer");
  const older = h("button", { class: "small", "data-testid": "history-older" }, "older ›");
  const pageInfo = h("span", { class: "ops-sub", "data-testid": "history-page" }, "");
  const historyError = h("div", { class: "ops-error", "data-testid": "history-error", hidden: true });
  const historyBody = h("tbody", {});
  const historyPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "History"),
    h(
      "div",
      { class: "ops-actions" },
      "since ",
      form.since,
      " until ",
      form.until,
      " module ",
      form.module,
      " severity ",
      form.severity,
      " state ",
      form.state,
      apply,
      csv,
    ),
    historyError,
    h(
      "div",
      { class: "ops-scroll" },
      h(
        "table",
        { class: "ops-grid ops-dense", "data-testid": "alarm-history" },
        h(
          "thead",
          {},
          h(
            "tr",
            {},
            h("th", {}, "time"),
            h("th", {}, "alarm"),
            h("th", {}, "event"),
            h("th", {}, "state"),
            h("th", {}, "severity"),
            h("th", {}, "text"),
            h("th", {}, "by / note"),
          ),
        ),
        historyBody,
      ),
    ),
    h("div", { class: "ops-actions" }, newer, older, pageInfo),
  );

  let offset = 0;
  let query: HistoryQuery = { limit: PAGE, offset: 0 };
  const historyRow = (t: AlarmTransition) =>
    h(
      "tr",
      { "data-seq": t.seq },
      h("td", { class: "mono nowrap", title: t.time }, formatTime(t.time)),
      h("td", { class: "mono nowrap" }, t.key),
      h("td", { class: "nowrap kind" }, t.event),
      h("td", { class: `state ${stateLevel(t.state)}` }, stateText(t.state)),
      h("td", {}, t.severity),
      h("td", { class: "wrap" }, t.text, t.detail ? h("div", { class: "ops-sub" }, t.detail) : null),
      h("td", { class: "wrap" }, [t.who?.name, t.note].filter(Boolean).join(" · ")),
    );
  const loadHistory = async () => {
    const q = historyQuery(
      {
        since: form.since.value,
        until: form.until.value,
        module: form.module.value,
        severity: form.severity.value,
        state: form.state.value,
      },
      PAGE,
      offset,
    );
    if (!q.ok) {
      historyError.hidden = false;
      setText(historyError, q.error);
      return;
    }
    query = q.query;
    try {
      const page = unwrap(await ctx.api.GET("/api/v1/alarms/history", { params: { query } }));
      historyError.hidden = true;
      historyBody.replaceChildren(...page.transitions.map(historyRow));
      setText(pageInfo, pageText(offset, page.transitions.length, page.total));
      newer.disabled = offset === 0;
      older.disabled = offset + page.transitions.length >= page.total;
    } catch (e) {
      historyError.hidden = false;
      setText(historyError, `history: ${errorText(e)}`);
    }
  };
  apply.addEventListener("click", () => {
    offset = 0;
    void loadHistory();
  });
  newer.addEventListener("click", () => {
    offset = Math.max(0, offset - PAGE);
    void loadHistory();
  });
  older.addEventListener("click", () => {
    offset += PAGE;
    void loadHistory();
  });
  csv.addEventListener("click", async () => {
    // a download: fetched (with the session cookie), then handed to the browser as a file
    try {
      const r = await fetch(csvPath(query), { credentials: "same-origin" });
      if (!r.ok) throw new ApiError(r.status, detailOf(await r.json().catch(() => r.statusText)));
      const name = /filename="([^"]+)"/.exec(r.headers.get("Content-Disposition") ?? "")?.[1] ?? "alarms.csv";
      const a = h("a", { href: URL.createObjectURL(await r.blob()), download: name });
      a.click();
      setTimeout(() => URL.revokeObjectURL(a.href), 10_000);
    } catch (e) {
      historyError.hidden = false;
      setText(historyError, `CSV export: ${errorText(e)}`);
    }
  });

  root.append(h("div", { class: "ops-page", "data-testid": "alarms-page" }, listPanel, historyPanel));

  let lastSeq = 0;
  const stop = ctx.alarms.listen((v, connected) => {
    view = v;
    const banner = bannerOf(v, connected);
    setText(info, ` — ${banner.text}`);
    setClass(info, `ops-sub ${banner.level === "muted" ? "" : banner.level}`);
    render();
    const seq = v.recent[0]?.seq ?? 0;
    if (seq !== lastSeq && offset === 0) void loadHistory(); // new transitions: the first page follows
    lastSeq = seq;
  });
  void loadHistory();
  return stop;
};
