// schedule.ts -- the schedule page: the slot table (the paper's Table 3) and the timing of one
// macro period (its Figure 2) drawn from the modules' measured execution times, refreshed every
// 2 s; a slot can be zoomed into, down to the busy part at its start.
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { errorText, h, poll, setText } from "../ops/dom";
import { renderSlotTable } from "../ops/slot-table-view";
import { buildSlotTable, buildTimeline, type Timeline, viewRange } from "../ops/timeline";
import { renderTimeline, timelineLegend } from "../ops/timeline-svg";
import type { ModuleInfo, Schedule } from "../ops/types";
import { formatNs, formatPercent } from "../ops/units";

export const schedulePage: Page = (root, ctx) => {
  let schedule: Schedule | null = null;
  let modules: ModuleInfo[] = [];
  let timeline: Timeline | null = null;
  let slot: number | null = null;
  let busyOnly = false;
  let tableKey = "";

  const info = h("span", { class: "ops-sub", "data-testid": "schedule-info" });
  const error = h("div", { class: "ops-error", "data-testid": "schedule-error", hidden: true });
  const tableHolder = h("div", {});
  const zoom = h("select", { "data-testid": "zoom", "aria-label": "zoom" });
  const busy = h("input", { type: "checkbox", "data-testid": "zoom-busy" });
  const prev = h("button", { class: "small", "data-testid": "zoom-prev", title: "previous slot" }, "◀");
  const next = h("button", { class: "small", "data-testid": "zoom-next", title: "next slot" }, "▶");
  const range = h("span", { class: "ops-sub num", "data-testid": "zoom-range" });
  const canvas = h("div", { class: "ops-timeline", "data-testid": "timeline" });
  const summary = h("div", { class: "ops-sub", "data-testid": "timeline-summary" });

  const timelinePanel = h(
    "section",
    { class: "panel ops-panel" },
    h(
      "h3",
      {},
      "One macro period",
      h("span", { class: "ops-sub" }, " — measured execution times to scale, per executor, in run order"),
    ),
    h(
      "div",
      { class: "ops-actions" },
      h("label", {}, "zoom ", zoom),
      prev,
      next,
      h("label", { title: "the part of the slot where modules run, with a margin" }, busy, " busy part only"),
      range,
    ),
    canvas,
    summary,
    timelineLegend(),
  );
  const tablePanel = h("section", { class: "panel ops-panel" }, h("h3", {}, "Slot table", info), tableHolder);

  root.append(h("div", { class: "ops-page", "data-testid": "schedule" }, error, tablePanel, timelinePanel));

  const setSlot = (s: number | null) => {
    slot = s;
    tableKey = "";
    draw();
  };
  zoom.addEventListener("change", () => setSlot(zoom.value === "" ? null : Number(zoom.value)));
  busy.addEventListener("change", () => {
    busyOnly = busy.checked;
    draw();
  });
  const step = (d: number) => {
    if (!timeline) return;
    const n = timeline.slots;
    setSlot(slot === null ? (d > 0 ? 0 : n - 1) : (slot + d + n) % n);
  };
  prev.addEventListener("click", () => step(-1));
  next.addEventListener("click", () => step(1));

  function draw(): void {
    if (!schedule) return;
    timeline = buildTimeline(schedule, modules);
    if (slot !== null && slot >= timeline.slots) slot = null;

    // the slot table: only when it changed (it can be long)
    const key = JSON.stringify([schedule.slots, schedule.modules, slot]);
    if (key !== tableKey) {
      tableKey = key;
      tableHolder.replaceChildren(
        renderSlotTable(buildSlotTable(schedule), {
          testid: "slot-table",
          onSlot: (s) => setSlot(s === slot ? null : s),
          selected: slot,
        }),
      );
      const options = [h("option", { value: "" }, `whole macro period (${formatNs(schedule.macro_period_ns)})`)];
      for (let i = 0; i < timeline.slots; i++)
        options.push(h("option", { value: i }, `slot ${i} (+${formatNs(i * schedule.basic_period_ns)})`));
      zoom.replaceChildren(...options);
    }
    zoom.value = slot === null ? "" : String(slot);

    const [from, to] = viewRange(timeline, slot, busyOnly);
    setText(range, `${formatNs(from)} … ${formatNs(to)} (${formatNs(to - from)} wide)`);
    const width = Math.max(480, canvas.clientWidth || root.clientWidth - 40);
    canvas.replaceChildren(renderTimeline(timeline, from, to, { width, onSlot: (s) => setSlot(s) }));

    const parts = timeline.lanes.map((l) => {
      const over = l.boxes.some((b) => b.overflow);
      return `${l.executor}: busiest slot ${formatNs(l.busiestNs, 3)} of ${formatNs(timeline!.basicNs)} (${formatPercent(l.busiestNs / timeline!.basicNs)})${over ? " — runs past its slot" : ""}`;
    });
    setText(summary, parts.join(" · ") + " · stacked by exec p99 since irpd started");
  }

  const schedulePoll = poll(
    async () => {
      const [s, m] = await Promise.all([
        ctx.api.GET("/api/v1/schedule").then((r) => unwrap(r) as unknown as Schedule),
        ctx.api.GET("/api/v1/modules").then((r) => unwrap(r) as unknown as ModuleInfo[]),
      ]);
      schedule = s;
      modules = m;
      error.hidden = true;
      root.querySelector(".ops-page")?.classList.remove("stale");
      setText(info, ` — the paper's Table 3: which modules each basic period runs`);
      draw();
    },
    2000,
    (e) => {
      error.hidden = false;
      setText(error, `${errorText(e)} — retrying every 2 s; what is shown is stale`);
      root.querySelector(".ops-page")?.classList.add("stale");
    },
  );
  const onResize = () => draw();
  window.addEventListener("resize", onResize);
  return () => {
    schedulePoll.stop();
    window.removeEventListener("resize", onResize);
  };
};
