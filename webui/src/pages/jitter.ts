// jitter.ts -- the jitter dashboard: for the dispatcher and each module, the histograms of jitter,
// latency and execution time (GET /jitter/histograms, polled every second; cumulative since irpd
// started, the last interval drawn over them), their p50/p99/max, and jitter over time: each
// poll interval's p50/p99/max from the difference of two polls, with the overruns and deadline
// misses of the interval marked in red.
import "../plot/plot.css";
import uPlot from "uplot";
import { ApiError, unwrap } from "../api/client";
import type { components } from "../api/schema";
import type { Page } from "../app/context";
import { diffHist, figures, type Hist, logBins } from "../plot/hist";
import { drawHistogram } from "../plot/histchart";
import { fmtNs } from "../plot/ticks";
import { wallClockRange } from "../plot/timeaxis";

type Record = components["schemas"]["HistogramRecord"];
type Histograms = components["schemas"]["Histograms"];

const POLL_MS = 1000;
const KEEP = 600; // intervals on the time axis (10 min)
const MIN_SPAN_S = 30; // the time axis's shortest window, while fewer intervals are there
const PER_DECADE = 8;
const HIST_H = 130;
const TIME_H = 180;
const KINDS = [
  ["jitter_ns", "jitter"],
  ["latency_ns", "latency"],
  ["exec_ns", "exec"],
] as const;
type Kind = (typeof KINDS)[number][0];

interface Track {
  key: string;
  /** the record's name, or dispatcher-<executor> for a dispatcher whose name another record has
   * (testids use it) */
  name: string;
  kind: string;
  rec: Record;
  prev: Record | null;
  interval: Partial<{ [K in Kind]: Hist }>;
  times: number[];
  min: (number | null)[];
  p50: (number | null)[];
  p99: (number | null)[];
  max: (number | null)[];
  overruns: number[];
  missed: number[];
  view: TrackView | null;
}

interface TrackView {
  card: HTMLElement;
  counts: HTMLElement;
  hists: { [K in Kind]: { canvas: HTMLCanvasElement; figs: HTMLElement } };
  chart: uPlot;
  timeHost: HTMLElement;
}

function esc(s: string): string {
  return s.replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

const us = (v: number | null) => (v === null ? null : v / 1e3);

/** A record's identity across polls: a dispatcher by its executor, a module by its name. */
const keyOf = (r: Record) => (r.kind === "dispatcher" ? `dispatcher/${r.executor}` : `module/${r.name}`);

/** One poll interval of a record, appended to its track. */
function advance(tr: Track, cur: Record, t: number): void {
  const prev = tr.prev;
  tr.rec = cur;
  tr.prev = cur;
  if (!prev) return; // the first poll only sets the baseline
  let restarted = cur.runs < prev.runs;
  for (const [k] of KINDS) {
    const d = restarted ? null : diffHist(cur[k], prev[k]);
    if (!d) restarted = true;
    tr.interval[k] = d ?? cur[k];
  }
  if (restarted) for (const [k] of KINDS) tr.interval[k] = cur[k];
  const f = figures(tr.interval.jitter_ns!);
  tr.times.push(t);
  tr.min.push(us(f.min));
  tr.p50.push(us(f.p50));
  tr.p99.push(us(f.p99));
  tr.max.push(us(f.max));
  tr.overruns.push(restarted ? cur.overruns : Math.max(0, cur.overruns - prev.overruns));
  tr.missed.push(restarted ? cur.missed : Math.max(0, cur.missed - prev.missed));
  if (tr.times.length > KEEP)
    for (const a of [tr.times, tr.min, tr.p50, tr.p99, tr.max, tr.overruns, tr.missed]) a.splice(0, a.length - KEEP);
}

/** Red lines at the intervals with overruns, dashed dark red at those with deadline misses. */
function markers(tr: Track) {
  return (u: uPlot) => {
    const g = u.ctx;
    const { top, height } = u.bbox;
    g.save();
    g.lineWidth = 2 * uPlot.pxRatio;
    for (const [arr, color, dash] of [
      [tr.overruns, "#c62828", []],
      [tr.missed, "#8e0000", [4, 3]],
    ] as const) {
      g.strokeStyle = color;
      g.setLineDash(dash.map((d) => d * uPlot.pxRatio));
      g.beginPath();
      for (let i = 0; i < arr.length; i++) {
        if (!arr[i]) continue;
        const x = Math.round(u.valToPos(tr.times[i], "x", true));
        g.moveTo(x, top);
        g.lineTo(x, top + height);
      }
      g.stroke();
    }
    g.restore();
  };
}

export const jitterPage: Page = (root, ctx) => {
  root.innerHTML = `
    <div class="jit-bar">
      <strong>Show:</strong> <span class="jit-pick" data-testid="jitter-pick"></span>
      <span class="muted" data-testid="jitter-status"></span>
      <span class="bad" data-testid="jitter-error"></span>
    </div>
    <div class="jit-cards" data-testid="jitter-cards"></div>`;
  const pickEl = root.querySelector<HTMLElement>(".jit-pick")!;
  const cardsEl = root.querySelector<HTMLElement>(".jit-cards")!;
  const statusEl = root.querySelector<HTMLElement>("[data-testid=jitter-status]")!;
  const errorEl = root.querySelector<HTMLElement>("[data-testid=jitter-error]")!;
  const tracks = new Map<string, Track>();
  const hidden = new Set<string>();
  let order: string[] = [];
  let alive = true;
  let timer: ReturnType<typeof setTimeout> | null = null;

  const makeView = (tr: Track): TrackView => {
    const card = document.createElement("section");
    card.className = "jit-card";
    card.dataset.testid = `jitter-card-${tr.name}`;
    card.innerHTML = `
      <h3>${esc(tr.name)} <span class="kind">${esc(tr.kind)} · executor ${esc(tr.rec.executor)}</span></h3>
      <div class="jit-counts" data-testid="counts-${esc(tr.name)}"></div>
      <div class="jit-grid">${KINDS.map(
        ([k, label]) => `
        <div class="jit-hist" data-testid="${k === "jitter_ns" ? `hist-${esc(tr.name)}` : `hist-${label}-${esc(tr.name)}`}">
          <h4>${label}</h4><div class="figs" data-kind="${k}" data-testid="figs-${label}-${esc(tr.name)}"></div><canvas data-kind="${k}"></canvas>
        </div>`,
      ).join("")}</div>
      <div class="jit-time">
        <h4>jitter per ${POLL_MS / 1000} s interval (µs) <span class="legend-note">red: overruns · dashed dark red: deadline misses</span></h4>
        <div data-testid="jitter-time-${esc(tr.name)}"></div>
      </div>`;
    const hists = {} as TrackView["hists"];
    for (const [k] of KINDS)
      hists[k] = {
        canvas: card.querySelector<HTMLCanvasElement>(`canvas[data-kind=${k}]`)!,
        figs: card.querySelector<HTMLElement>(`.figs[data-kind=${k}]`)!,
      };
    const timeHost = card.querySelector<HTMLElement>(`.jit-time > div`)!;
    cardsEl.appendChild(card);
    const chart = new uPlot(
      {
        width: Math.max(300, timeHost.clientWidth || 800),
        height: TIME_H,
        // x: each poll's wall-clock time (Unix s), from the first poll to the newest, MIN_SPAN_S at least
        scales: { x: { time: true, range: () => wallClockRange(tr.times, MIN_SPAN_S) } },
        series: [
          {},
          { label: "min", stroke: "#90a4ae", width: 1, spanGaps: false },
          { label: "p50", stroke: "#2e7d32", width: 1.5, spanGaps: false },
          { label: "p99", stroke: "#ef6c00", width: 1.5, spanGaps: false },
          { label: "max", stroke: "#c62828", width: 1, spanGaps: false },
        ],
        axes: [
          { stroke: "#5f6b76", grid: { stroke: "#eef1f4" } },
          { stroke: "#5f6b76", size: 60, grid: { stroke: "#eef1f4" } },
        ],
        cursor: { points: { show: false } },
        hooks: { draw: [markers(tr)] },
      },
      [[], [], [], [], []],
      timeHost,
    );
    return { card, counts: card.querySelector(".jit-counts")!, hists, chart, timeHost };
  };

  const render = (tr: Track) => {
    tr.view ??= makeView(tr);
    const v = tr.view;
    const r = tr.rec;
    const ov = tr.overruns.reduce((a, b) => a + b, 0);
    const ms = tr.missed.reduce((a, b) => a + b, 0);
    v.counts.innerHTML =
      `<span>runs ${r.runs}</span><span class="${r.overruns ? "bad" : ""}">overruns ${r.overruns}</span>` +
      `<span class="${r.missed ? "bad" : ""}">missed ${r.missed}</span><span>skipped ${r.skipped}</span><span class="${r.errors ? "bad" : ""}">errors ${r.errors}</span>` +
      `<span class="muted">on this page: ${ov} overruns, ${ms} misses</span>`;
    v.card.dataset.overruns = String(ov);
    v.card.dataset.missed = String(ms);
    for (const [k] of KINDS) {
      const all = figures(r[k]);
      const last = tr.interval[k] ? figures(tr.interval[k]!) : null;
      const h = v.hists[k];
      h.figs.textContent =
        `p50 ${fmtNs(all.p50)} · p99 ${fmtNs(all.p99)} · max ${fmtNs(all.max)}` +
        (last ? ` | last poll: p50 ${fmtNs(last.p50)} · p99 ${fmtNs(last.p99)} · max ${fmtNs(last.max)}` : "");
      const w = Math.max(200, h.canvas.parentElement!.clientWidth);
      drawHistogram(
        h.canvas,
        w,
        HIST_H,
        logBins(r[k].buckets, PER_DECADE),
        last ? logBins(tr.interval[k]!.buckets, PER_DECADE) : null,
        [
          { label: "p50", ns: all.p50, color: "#2e7d32" },
          { label: "p99", ns: all.p99, color: "#ef6c00" },
          { label: "max", ns: all.max, color: "#c62828" },
        ],
        PER_DECADE,
      );
    }
    const w = Math.max(300, v.timeHost.clientWidth);
    if (Math.abs(w - v.chart.width) > 2) v.chart.setSize({ width: w, height: TIME_H });
    v.chart.setData([tr.times, tr.min, tr.p50, tr.p99, tr.max]);
  };

  const renderPick = () => {
    const have = new Set(Array.from(pickEl.querySelectorAll<HTMLInputElement>("input"), (i) => i.dataset.name!));
    if (order.length === have.size && order.every((n) => have.has(n))) return;
    pickEl.innerHTML = order
      .map((k) => {
        const n = tracks.get(k)!.name;
        return `<label><input type="checkbox" data-name="${esc(k)}" data-testid="jitter-pick-${esc(n)}" ${hidden.has(k) ? "" : "checked"} /> ${esc(n)}</label>`;
      })
      .join("");
    for (const i of pickEl.querySelectorAll<HTMLInputElement>("input"))
      i.onchange = () => {
        if (i.checked) hidden.delete(i.dataset.name!);
        else hidden.add(i.dataset.name!);
        layout();
      };
  };

  /** Draws the picked records' cards, in order (dispatchers first). */
  const layout = () => {
    let i = 0;
    for (const n of order) {
      const tr = tracks.get(n)!;
      if (hidden.has(n)) {
        if (tr.view) tr.view.card.hidden = true;
        continue;
      }
      render(tr);
      const card = tr.view!.card;
      card.hidden = false;
      if (cardsEl.children[i] !== card) cardsEl.insertBefore(card, cardsEl.children[i] ?? null);
      i++;
    }
  };

  const poll = async () => {
    try {
      const data: Histograms = unwrap(await ctx.api.GET("/api/v1/jitter/histograms"));
      if (!alive) return;
      const t = Date.now() / 1000;
      const seen = new Set<string>();
      const names = new Map<string, number>();
      for (const rec of data.records) names.set(rec.name, (names.get(rec.name) ?? 0) + 1);
      for (const rec of data.records) {
        const key = keyOf(rec);
        seen.add(key);
        let tr = tracks.get(key);
        if (!tr) {
          // module names are unique; a dispatcher sharing its name is told apart by its executor
          const name = names.get(rec.name)! > 1 && rec.kind === "dispatcher" ? `dispatcher-${rec.executor}` : rec.name;
          tr = {
            key,
            name,
            kind: rec.kind,
            rec,
            prev: null,
            interval: {},
            times: [],
            min: [],
            p50: [],
            p99: [],
            max: [],
            overruns: [],
            missed: [],
            view: null,
          };
          tracks.set(key, tr);
        }
        advance(tr, rec, t);
      }
      for (const [n, tr] of tracks)
        if (!seen.has(n)) {
          tr.view?.chart.destroy();
          tr.view?.card.remove();
          tracks.delete(n);
        }
      order = [...tracks.values()]
        .sort((a, b) => Number(b.kind === "dispatcher") - Number(a.kind === "dispatcher"))
        .map((tr) => tr.key);
      renderPick();
      layout();
      statusEl.textContent = `${data.cycles} cycles · ${data.records.length} records · updated ${new Date().toLocaleTimeString()}`;
      errorEl.textContent = "";
    } catch (e) {
      errorEl.textContent = `GET /jitter/histograms: ${e instanceof ApiError ? `${e.status}: ${e.message}` : String(e)}`;
    } finally {
      if (alive) timer = setTimeout(() => void poll(), POLL_MS);
    }
  };
  void poll();

  return () => {
    alive = false;
    if (timer) clearTimeout(timer);
    for (const tr of tracks.values()) tr.view?.chart.destroy();
  };
};
