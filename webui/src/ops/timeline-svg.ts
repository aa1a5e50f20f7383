// timeline-svg.ts -- draws a Timeline (timeline.ts) as SVG: one lane per executor, the slot
// boundaries, the modules' execution times to scale, the sporadic part, the time left over.
import { svgEl as el } from "./svg";
import { type Box, type Timeline, ticks } from "./timeline";
import { formatNs } from "./units";

const LABEL_W = 110;
const AXIS_H = 34;
const LANE_H = 56;
const PAD = 6;

function titled<T extends SVGElement>(e: T, title: string): T {
  e.appendChild(el("title", {}, title));
  return e;
}

export interface TimelineOptions {
  width: number;
  /** called with a slot index when its header is clicked */
  onSlot?: (slot: number) => void;
}

function defs(): SVGDefsElement {
  const d = el("defs", {});
  const hatch = el("pattern", {
    id: "tl-hatch",
    width: 6,
    height: 6,
    patternUnits: "userSpaceOnUse",
    patternTransform: "rotate(45)",
  });
  hatch.appendChild(el("rect", { width: 6, height: 6, class: "tl-sporadic-bg" }));
  hatch.appendChild(el("line", { x1: 0, y1: 0, x2: 0, y2: 6, class: "tl-sporadic-line" }));
  const dots = el("pattern", { id: "tl-dots", width: 5, height: 5, patternUnits: "userSpaceOnUse" });
  dots.appendChild(el("circle", { cx: 2.5, cy: 2.5, r: 0.8, class: "tl-idle-dot" }));
  d.append(hatch, dots);
  return d;
}

function boxTitle(b: Box): string {
  if (!b.measured) return `${b.module} (${b.kind}): no run measured`;
  const kind = b.kind === "sporadic" ? "sporadic, event handler; runs when its event fires" : "periodic";
  return `${b.module} (${kind}), slot ${b.slot}\nstarts ≈ +${formatNs(Math.round(b.start))} (stacked by p99)\nexec p50 ${formatNs(b.p50)}, p99 ${formatNs(b.p99)}, max ${formatNs(b.max)}${b.overflow ? "\nruns past the end of its slot" : ""}`;
}

/** The SVG of `tl` between `from` and `to` ns. */
export function renderTimeline(tl: Timeline, from: number, to: number, opt: TimelineOptions): SVGSVGElement {
  const plotW = Math.max(100, opt.width - LABEL_W - PAD);
  const h = AXIS_H + tl.lanes.length * LANE_H + PAD;
  const svg = el("svg", { width: opt.width, height: h, viewBox: `0 0 ${opt.width} ${h}`, class: "tl", role: "img" });
  svg.appendChild(defs());
  const x = (ns: number) => LABEL_W + ((ns - from) / (to - from)) * plotW;
  const clipX = (ns: number) => Math.min(LABEL_W + plotW, Math.max(LABEL_W, x(ns)));
  const w = (a: number, b: number, min = 0) => Math.max(min, clipX(b) - clipX(a));
  // [a, b) overlaps [from, to); a zero-length mark counts at its instant
  const visible = (a: number, b: number) => a < to && (b > from || (a === b && a >= from));

  // axis
  const axis = el("g", { class: "tl-axis" });
  for (const t of ticks(from, to, Math.max(2, Math.floor(plotW / 90)))) {
    axis.appendChild(el("line", { x1: x(t), x2: x(t), y1: AXIS_H - 6, y2: h - PAD, class: "tl-tick" }));
    // labels near the ends are anchored inside the plot, so they are not cut off
    const anchor = x(t) > LABEL_W + plotW - 24 ? "end" : x(t) < LABEL_W + 12 ? "start" : "middle";
    axis.appendChild(
      el("text", { x: x(t), y: AXIS_H - 9, class: "tl-tick-label", "text-anchor": anchor }, formatNs(t)),
    );
  }
  svg.appendChild(axis);

  // slot boundaries and headers
  const slotsG = el("g", { class: "tl-slots" });
  for (let s = 0; s < tl.slots; s++) {
    const a = s * tl.basicNs;
    const b = a + tl.basicNs;
    if (!visible(a, b)) continue;
    if (a >= from) slotsG.appendChild(el("line", { x1: x(a), x2: x(a), y1: 4, y2: h - PAD, class: "tl-boundary" }));
    const header = titled(
      el("rect", { x: clipX(a), y: 2, width: w(a, b), height: 14, class: "tl-slot-head", "data-slot": s }),
      `slot ${s}: +${formatNs(a)} … +${formatNs(b)}${opt.onSlot ? " (click to zoom)" : ""}`,
    );
    if (opt.onSlot) header.addEventListener("click", () => opt.onSlot!(s));
    slotsG.appendChild(header);
    if (w(a, b) > 34) slotsG.appendChild(el("text", { x: clipX(a) + 4, y: 13, class: "tl-slot-label" }, `slot ${s}`));
  }
  if (tl.slots * tl.basicNs <= to) {
    const end = tl.slots * tl.basicNs;
    slotsG.appendChild(el("line", { x1: x(end), x2: x(end), y1: 4, y2: h - PAD, class: "tl-boundary" }));
  }
  svg.appendChild(slotsG);

  tl.lanes.forEach((lane, i) => {
    const y = AXIS_H + i * LANE_H;
    const g = el("g", { class: "tl-lane", "data-executor": lane.executor });
    g.appendChild(el("rect", { x: LABEL_W, y: y + 2, width: plotW, height: LANE_H - 4, class: "tl-lane-bg" }));
    g.appendChild(el("text", { x: 4, y: y + LANE_H / 2 - 2, class: "tl-lane-label" }, lane.executor));
    g.appendChild(
      el("text", { x: 4, y: y + LANE_H / 2 + 11, class: "tl-lane-sub" }, `busiest ${formatNs(lane.busiestNs, 3)}`),
    );
    for (const idle of lane.idle) {
      if (!visible(idle.start, idle.end)) continue;
      const r = titled(
        el("rect", {
          x: clipX(idle.start),
          y: y + 6,
          width: w(idle.start, idle.end),
          height: LANE_H - 12,
          class: "tl-idle",
        }),
        `slot ${idle.slot}: ${formatNs(idle.end - idle.start)} left over${lane.nonReal.length ? ` — non-real: ${lane.nonReal.join(", ")}` : ""}`,
      );
      g.appendChild(r);
      if (w(idle.start, idle.end) > 120)
        g.appendChild(
          el(
            "text",
            { x: clipX(idle.start) + 6, y: y + LANE_H / 2 + 4, class: "tl-idle-label" },
            `${lane.nonReal.length ? `non-real: ${lane.nonReal.join(", ")}` : "idle"} · ${formatNs(idle.end - idle.start, 3)}`,
          ),
        );
    }
    for (const b of lane.boxes) {
      const slotEnd = (b.slot + 1) * tl.basicNs;
      // the whisker to the max is cut at the end of the slot (a box itself may run past it)
      const whiskerEnd = Math.min(b.start + b.max, Math.max(slotEnd, b.start + b.p99));
      if (!visible(b.start, Math.max(b.start + b.p99, whiskerEnd))) continue;
      const bg = el("g", {
        class: `tl-box tl-${b.kind}${b.overflow ? " tl-overflow" : ""}${b.measured ? "" : " tl-unmeasured"}`,
        "data-module": b.module,
        "data-slot": b.slot,
      });
      titled(bg, boxTitle(b));
      const top = y + 8;
      const bh = LANE_H - 16;
      if (!b.measured) {
        bg.appendChild(
          el("line", { x1: clipX(b.start), x2: clipX(b.start), y1: top, y2: top + bh, class: "tl-marker" }),
        );
      } else {
        bg.appendChild(
          el("rect", { x: clipX(b.start), y: top, width: w(b.start, b.start + b.p99, 1), height: bh, class: "tl-p99" }),
        );
        bg.appendChild(
          el("rect", { x: clipX(b.start), y: top, width: w(b.start, b.start + b.p50, 1), height: bh, class: "tl-p50" }),
        );
        // the whisker to the max, along the box's bottom edge
        if (b.max > b.p99 && visible(b.start + b.p99, whiskerEnd)) {
          const wy = top + bh - 1;
          bg.appendChild(
            el("line", { x1: clipX(b.start + b.p99), x2: clipX(whiskerEnd), y1: wy, y2: wy, class: "tl-max" }),
          );
          if (whiskerEnd < b.start + b.max && whiskerEnd <= to)
            bg.appendChild(
              el("path", {
                d: `M${x(whiskerEnd) - 5},${wy - 3} L${x(whiskerEnd)},${wy} L${x(whiskerEnd) - 5},${wy + 3}`,
                class: "tl-max",
              }),
            );
        }
      }
      if (w(b.start, b.start + b.p99) > 8 + b.module.length * 6.5)
        bg.appendChild(el("text", { x: clipX(b.start) + 3, y: top + bh / 2 + 4, class: "tl-box-label" }, b.module));
      g.appendChild(bg);
    }
    svg.appendChild(g);
  });
  return svg;
}

/** The legend, as HTML. */
export function timelineLegend(): HTMLElement {
  const div = document.createElement("div");
  div.className = "tl-legend";
  div.dataset.testid = "timeline-legend";
  const item = (cls: string, text: string) =>
    `<span class="tl-key"><svg width="22" height="12"><rect width="22" height="12" class="${cls}" /></svg>${text}</span>`;
  div.innerHTML = [
    item("tl-p50", "periodic: exec p50"),
    item("tl-p99", "… up to p99"),
    `<span class="tl-key"><svg width="22" height="12"><line x1="0" x2="22" y1="6" y2="6" class="tl-max" /></svg>… up to max</span>`,
    `<span class="tl-key"><svg width="22" height="12"><defs><pattern id="lg-hatch" width="6" height="6" patternUnits="userSpaceOnUse" patternTransform="rotate(45)"><rect width="6" height="6" class="tl-sporadic-bg"/><line x1="0" y1="0" x2="0" y2="6" class="tl-sporadic-line"/></pattern></defs><rect width="22" height="12" fill="url(#lg-hatch)" stroke="#5f6b76" stroke-width="0.5"/></svg>sporadic (event handler, when its event fires)</span>`,
    item("tl-idle", "left over: non-real work"),
    item("tl-overflow-key", "runs past its slot"),
    `<span class="tl-key"><svg width="10" height="12"><line x1="5" x2="5" y1="0" y2="12" class="tl-boundary" /></svg>slot boundary</span>`,
  ].join("");
  return div;
}
