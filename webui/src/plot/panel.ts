// panel.ts -- one plot panel of the variables page: its variables, its own subscription to the
// sample stream (every sample, no decimation on the wire), a ring holding its window, and a uPlot
// time chart or an x–y canvas drawn at most once per animation frame.  Pausing or zooming (drag
// on the chart) freezes a copy of the samples while the ring keeps filling; double-click or
// Resume goes back to live.  A panel made without a stream shows a fixed table of rows instead
// (showRows: a capture's shots on the Scope page), with the same zoom, cursor and x–y mode, its x
// axis in seconds from a mark (the trigger).
import uPlot from "uplot";
import type { Samples, StreamClient } from "../stream/stream";
import { download, windowCsv } from "./csv";
import { bucketSize, clearDraw, type DrawData, decimateRange, emptyDraw, LiveDecimator } from "./decimate";
import { COLORS, drawLines, drawMarks } from "./lines";
import { shortLabels } from "./paths";
import { type FixedRows, SampleRing } from "./ring";
import type { PlotStats } from "./stats";
import { XYPlot } from "./xy";

export type Mode = "time" | "xy";

export interface PanelConfig {
  paths: string[];
  mode: Mode;
  windowS: number;
  /** the x–y mode's variables (paths of this panel) */
  xy: [string | null, string | null];
}

/** What the page gives its panels. */
export interface PanelEnv {
  /** null: a panel of fixed rows (showRows), not fed by the stream */
  stream: StreamClient | null;
  stats: PlotStats;
  /** CLOCK_MONOTONIC → wall clock, fixed at the first sample the page saw (for the time axis) */
  clock: { offset: number | null };
  /** whether a path is a variable of the running layout (one unknown path would make irpd refuse
   * the whole stream subscription) */
  known(path: string): boolean;
  /** a variable's tooltip, its path and type (paths.ts varTitle); the path when not given */
  describe?(path: string): string;
  notify(message: string, kind?: "info" | "error"): void;
  changed(): void;
  remove(p: PlotPanel): void;
  activate(p: PlotPanel): void;
}

export const WINDOWS_S = [1, 2, 5, 10, 20, 30, 60];
export const MAX_VARS = 16;
/** a panel's ring and its frozen copy stay under 64 MiB each */
const BUDGET_DOUBLES = 1 << 23;
const HEIGHT = 280;

/** Wall-clock seconds → "12:03:45.123". */
function clockTime(s: number): string {
  const d = new Date(s * 1000);
  const p = (n: number, w = 2) => String(n).padStart(w, "0");
  return `${p(d.getHours())}:${p(d.getMinutes())}:${p(d.getSeconds())}.${p(d.getMilliseconds(), 3)}`;
}

function esc(s: string): string {
  return s.replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

export class PlotPanel {
  readonly el: HTMLElement;
  private ring: SampleRing | null = null;
  private periodS: number | null = null;
  private live: LiveDecimator | null = null;
  /** a copy of the ring taken when the view froze (pause or zoom), null while live */
  private frozen: SampleRing | null = null;
  /** the zoomed x-range (monotonic s) of the frozen copy, null: all of it */
  private zoom: [number, number] | null = null;
  private paused = false;
  private dirty = true;
  private draw: DrawData;
  private xRange: [number, number] | null = null;
  private chart: uPlot | null = null;
  private xy: XYPlot | null = null;
  private unsubscribe: (() => void) | null = null;
  private lastDropped: number | null = null;
  /** samples missing by seq that the agent's drop counter does not account for: the rows before a
   * changed subscription took effect, and those between two connections */
  private unaccounted = 0;
  private capped = false;
  private width = 600;
  /** a panel of fixed rows (no stream): its rows are `frozen`, its marks drawn over them */
  readonly fixed: boolean;
  private marks: FixedRows["marks"] = [];
  private resize: ResizeObserver;
  private host: HTMLElement;
  private info: HTMLElement;

  constructor(
    readonly id: number,
    readonly cfg: PanelConfig,
    private env: PanelEnv,
  ) {
    this.fixed = env.stream === null;
    this.draw = emptyDraw(cfg.paths.length);
    const el = document.createElement("section");
    el.className = "plot-panel";
    el.dataset.testid = `plot-panel-${id}`;
    el.innerHTML = `
      <header>
        <button class="title link-dark" data-testid="panel-title" title="the active panel (click a panel to make it active) gets the variables the tree's + adds">Plot ${id}</button>
        <label>mode <select data-testid="mode"><option value="time">time</option><option value="xy">x–y</option></select></label>
        <label>window <select data-testid="window">${WINDOWS_S.map((w) => `<option value="${w}">${w} s</option>`).join("")}</select></label>
        <button data-testid="pause">Pause</button>
        <button data-testid="csv" title="the samples in the visible x-range: seq, t, one column per variable">CSV</button>
        <span class="spacer"></span>
        <button class="danger" data-testid="remove-panel" title="remove this panel">✕</button>
      </header>
      <div class="vars">
        <span class="chips"></span>
        <input list="var-paths" placeholder="add a variable…" data-testid="panel-add" size="28" />
      </div>
      <div class="xy-pick" hidden>
        X <select data-testid="xy-x"></select> Y <select data-testid="xy-y"></select>
        <label><input type="checkbox" data-testid="xy-equal" checked /> equal scales</label>
      </div>
      <div class="plot-host"></div>
      <div class="panel-info" data-testid="panel-info"></div>`;
    this.el = el;
    if (this.fixed) {
      // what a table of fixed rows has no use for: a window, pause (it never moves), the stream's
      // variables, the visible window's CSV (a shot is exported whole from the recordings' list)
      for (const id of ["window", "pause", "csv", "remove-panel", "panel-add"])
        el.querySelector<HTMLElement>(`[data-testid=${id}]`)!.closest("label, button, input")!.remove();
      el.dataset.state = "fixed";
    }
    this.host = el.querySelector(".plot-host")!;
    this.info = el.querySelector(".panel-info")!;
    const q = <T extends HTMLElement>(id: string) => el.querySelector<T>(`[data-testid=${id}]`)!;
    const mode = q<HTMLSelectElement>("mode");
    mode.value = cfg.mode;
    mode.onchange = () => {
      cfg.mode = mode.value as Mode;
      this.build();
      env.changed();
    };
    el.addEventListener("pointerdown", () => env.activate(this));
    if (!this.fixed) {
      const win = q<HTMLSelectElement>("window");
      win.value = String(cfg.windowS);
      win.onchange = () => this.setWindow(Number(win.value));
      q("pause").onclick = () => (this.frozen ? this.resume() : this.pause());
      q("csv").onclick = () => this.exportCsv();
      q("remove-panel").onclick = () => env.remove(this);
      const add = q<HTMLInputElement>("panel-add");
      add.onchange = () => {
        const p = add.value.trim();
        add.value = "";
        if (p) this.addPath(p);
      };
    }
    const pickX = q<HTMLSelectElement>("xy-x");
    const pickY = q<HTMLSelectElement>("xy-y");
    pickX.onchange = pickY.onchange = () => {
      cfg.xy = [pickX.value || null, pickY.value || null];
      this.dirty = true;
      env.changed();
    };
    q<HTMLInputElement>("xy-equal").onchange = (ev) => {
      if (this.xy) this.xy.equal = (ev.target as HTMLInputElement).checked;
      this.dirty = true;
    };
    this.resize = new ResizeObserver(() => {
      const w = Math.max(200, Math.floor(this.host.clientWidth));
      if (w !== this.width) {
        this.width = w;
        this.chart?.setSize({ width: w, height: HEIGHT });
        this.live = null;
        this.dirty = true;
      }
    });
    this.resize.observe(this.host);
    this.build();
    this.subscribe();
  }

  get paths(): string[] {
    return this.cfg.paths;
  }

  setActive(on: boolean): void {
    this.el.classList.toggle("active", on);
  }

  /** Shows these rows (a panel of fixed rows only): their series, whole, unzoomed; the x–y
   * variables are kept when the new rows have them. */
  showRows(rows: FixedRows): void {
    if (!this.fixed) throw new Error("showRows: this panel follows the stream");
    this.frozen = SampleRing.of(rows);
    this.marks = rows.marks;
    this.zoom = null;
    this.cfg.paths = [...rows.names];
    const keep = (p: string | null) => (p && rows.names.includes(p) ? p : null);
    const [x, y] = this.cfg.xy.map(keep);
    this.cfg.xy = [x ?? rows.names[0] ?? null, y ?? rows.names.find((n) => n !== (x ?? rows.names[0])) ?? null];
    this.draw = emptyDraw(rows.names.length);
    this.build();
  }

  /** The mode and the x–y variables (a restored view); variables the panel lacks are dropped. */
  setView(mode: Mode, xy: readonly (string | null)[] | null): void {
    this.cfg.mode = mode;
    const keep = (p: string | null | undefined) => (p && this.cfg.paths.includes(p) ? p : null);
    if (xy) this.cfg.xy = [keep(xy[0]), keep(xy[1])];
    this.el.querySelector<HTMLSelectElement>("[data-testid=mode]")!.value = mode;
    this.build();
  }

  /** The rows shown (a panel of fixed rows), null before showRows. */
  get rows(): SampleRing | null {
    return this.fixed ? this.frozen : null;
  }

  /** Makes the panel draw again at its next frame (the page changed the mode, say). */
  redraw(): void {
    this.dirty = true;
  }

  // ---- variables --------------------------------------------------------------------------------
  addPath(path: string): boolean {
    if (this.cfg.paths.includes(path)) return true;
    if (!this.env.known(path)) {
      this.env.notify(`no variable "${path}" in the running layout`, "error");
      return false;
    }
    if (this.cfg.paths.length >= MAX_VARS) {
      this.env.notify(`Plot ${this.id} has ${MAX_VARS} variables already: add a panel`, "error");
      return false;
    }
    this.setPaths([...this.cfg.paths, path]);
    const [x, y] = this.cfg.xy;
    if (!x) this.cfg.xy = [path, y];
    else if (!y && x !== path) this.cfg.xy = [x, path];
    this.build();
    this.env.changed();
    return true;
  }

  removePath(path: string): void {
    this.setPaths(this.cfg.paths.filter((p) => p !== path));
    this.cfg.xy = this.cfg.xy.map((p) => (p === path ? null : p)) as [string | null, string | null];
    this.build();
    this.env.changed();
  }

  /** New variables: the kept ones keep their samples; new ones start empty. */
  private setPaths(paths: string[]): void {
    const map = paths.map((p) => this.cfg.paths.indexOf(p));
    if (this.ring) this.ring = this.ring.copy(this.ring.capacity, map);
    if (this.frozen) this.frozen = this.frozen.copy(this.frozen.capacity, map);
    this.cfg.paths = paths;
    this.live = null;
    this.draw = emptyDraw(paths.length);
    this.subscribe();
  }

  private subscribe(): void {
    if (!this.env.stream) return;
    const old = this.unsubscribe;
    // the new subscription first: the variables both have stay traced throughout
    this.unsubscribe = this.cfg.paths.length
      ? this.env.stream.subscribe(this.cfg.paths, (s) => this.onSamples(s))
      : null;
    old?.();
  }

  // ---- samples --------------------------------------------------------------------------------
  private onSamples(s: Samples): void {
    const n = s.t.length;
    if (n === 0 || !this.env.stream) return;
    // the basic period from the channels message (a new set may change it), else from the due times
    const statusPeriod = this.env.stream.status.basicPeriodNs;
    const period =
      statusPeriod !== null
        ? (statusPeriod / 1e9) * s.decimation
        : this.periodS !== null
          ? this.periodS
          : n > 1
            ? (s.t[n - 1] - s.t[0]) / (n - 1)
            : 1e-3;
    if (!this.ring || this.periodS === null || Math.abs(period - this.periodS) > 1e-12) {
      this.periodS = period;
      this.ring = this.makeRing(this.ring);
      this.live = null;
    }
    const cols = this.cfg.paths.map((p) => s.values.get(p));
    const r = this.ring.push(s.firstSeq, s.decimation, s.t, cols);
    if (r.reset) this.lastDropped = null;
    if (r.gap > 0) {
      // the agent's counter starts again at 0 on a new connection
      const agent = this.lastDropped === null ? 0 : Math.max(0, s.dropped - this.lastDropped);
      this.unaccounted += Math.max(0, r.gap - agent);
    }
    this.lastDropped = s.dropped;
    if (this.env.clock.offset === null) this.env.clock.offset = Date.now() / 1000 - s.t[n - 1];
    this.env.stats.samples += n;
    if (!this.frozen) this.dirty = true;
  }

  private capacity(): number {
    const period = this.periodS ?? 1e-3;
    const slack = Math.ceil(0.5 / period) + 1100;
    const need = Math.ceil(this.cfg.windowS / period) + slack;
    const most = Math.floor(BUDGET_DOUBLES / (this.cfg.paths.length + 2));
    this.capped = need > most;
    return Math.max(2048, Math.min(need, most));
  }

  private makeRing(from: SampleRing | null): SampleRing {
    const cap = this.capacity();
    return from ? from.copy(cap) : new SampleRing(cap, this.cfg.paths.length);
  }

  private setWindow(w: number): void {
    this.cfg.windowS = w;
    if (this.ring) this.ring = this.makeRing(this.ring);
    this.live = null;
    this.dirty = true;
    this.env.changed();
  }

  // ---- freezing ---------------------------------------------------------------------------------
  private pause(): void {
    if (!this.ring || this.ring.length === 0) return;
    this.paused = true;
    this.freeze();
    this.zoom = this.liveRange();
    this.dirty = true;
    this.updateButtons();
  }

  private freeze(): void {
    if (!this.frozen && this.ring) this.frozen = this.ring.copy();
  }

  resume(): void {
    if (this.fixed) {
      this.zoom = null; // fixed rows never go live: back to all of them
      this.dirty = true;
      this.updateButtons();
      return;
    }
    this.paused = false;
    this.frozen = null;
    this.zoom = null;
    this.dirty = true;
    this.updateButtons();
  }

  private updateButtons(): void {
    if (this.fixed) {
      this.el.dataset.state = this.zoom ? "zoomed" : "fixed";
      return;
    }
    const b = this.el.querySelector<HTMLButtonElement>("[data-testid=pause]")!;
    b.textContent = this.frozen ? "Resume" : "Pause";
    b.classList.toggle("on", !!this.frozen);
    this.el.dataset.state = this.frozen ? (this.paused ? "paused" : "zoomed") : "live";
  }

  /** What x values are shifted by: the wall clock's offset live, none for fixed rows. */
  private get xOffset(): number {
    return this.fixed ? 0 : (this.env.clock.offset ?? 0);
  }

  private liveRange(): [number, number] | null {
    const r = this.ring;
    if (!r || r.length === 0) return null;
    const tMax = r.tAt(r.length - 1);
    return [tMax - this.cfg.windowS, tMax];
  }

  /** The visible x-range in monotonic seconds, and the samples it is taken from. */
  visible(): { src: SampleRing; range: [number, number] } | null {
    if (this.frozen) {
      const f = this.frozen;
      if (f.length === 0) return null;
      return { src: f, range: this.zoom ?? [f.tAt(0), f.tAt(f.length - 1)] };
    }
    const range = this.liveRange();
    return range && this.ring ? { src: this.ring, range } : null;
  }

  private onSelect(u: uPlot): void {
    const sel = u.select;
    if (sel.width < 3) return;
    const off = this.xOffset;
    const a = u.posToVal(sel.left, "x") - off;
    const b = u.posToVal(sel.left + sel.width, "x") - off;
    u.setSelect({ left: 0, top: 0, width: 0, height: 0 }, false);
    this.freeze();
    this.zoom = [a, b];
    this.dirty = true;
    this.updateButtons();
  }

  private unzoom(): void {
    if ((this.paused || this.fixed) && this.frozen) this.zoom = null;
    else this.resume();
    this.dirty = true;
    this.updateButtons();
  }

  // ---- CSV ----------------------------------------------------------------------------------------
  exportCsv(): void {
    const v = this.visible();
    if (!v) {
      this.env.notify(`Plot ${this.id} has no samples yet`);
      return;
    }
    const parts = windowCsv(v.src, this.cfg.paths, v.range[0], v.range[1]);
    const [i0, i1] = v.src.range(v.range[0], v.range[1]);
    const name =
      i1 > i0
        ? `indurop-plot${this.id}-seq${v.src.seqAt(i0)}-${v.src.seqAt(i1 - 1)}.csv`
        : `indurop-plot${this.id}-empty.csv`;
    download(name, parts);
  }

  // ---- drawing ------------------------------------------------------------------------------------
  /** Rebuilds the chart (variables or mode changed). */
  private build(): void {
    this.chart?.destroy();
    this.chart = null;
    this.xy?.canvas.remove();
    this.xy = null;
    this.host.innerHTML = "";
    const chips = this.el.querySelector(".chips")!;
    const labels = shortLabels(this.cfg.paths);
    chips.innerHTML = this.cfg.paths
      .map(
        (p, i) =>
          `<span class="chip" data-testid="chip-${esc(p)}" title="${esc(this.env.describe?.(p) ?? p)}">${esc(labels[i])}<button data-path="${esc(p)}" title="remove">×</button></span>`,
      )
      .join("");
    // Each chip's colour set through the DOM: the page's Content-Security-Policy refuses style="" in markup.
    chips.querySelectorAll<HTMLElement>(".chip").forEach((chip, i) => {
      chip.style.borderColor = COLORS[i % COLORS.length];
    });
    for (const b of chips.querySelectorAll<HTMLButtonElement>("button"))
      b.onclick = () => this.removePath(b.dataset.path!);
    const pick = this.el.querySelector<HTMLElement>(".xy-pick")!;
    pick.hidden = this.cfg.mode !== "xy";
    for (const [i, id] of [
      [0, "xy-x"],
      [1, "xy-y"],
    ] as const) {
      const s = this.el.querySelector<HTMLSelectElement>(`[data-testid=${id}]`)!;
      s.innerHTML = `<option value="">—</option>` + this.cfg.paths.map((p) => `<option>${esc(p)}</option>`).join("");
      s.value = this.cfg.xy[i] ?? "";
    }
    this.width = Math.max(200, Math.floor(this.host.clientWidth || this.width));
    if (this.cfg.mode === "xy") {
      this.xy = new XYPlot(this.host);
      this.xy.equal = this.el.querySelector<HTMLInputElement>("[data-testid=xy-equal]")!.checked;
    } else {
      this.chart = this.makeChart();
    }
    this.live = null;
    this.dirty = true;
    this.updateButtons();
  }

  private makeChart(): uPlot {
    const fixed = this.fixed;
    const opts: uPlot.Options = {
      width: this.width,
      height: HEIGHT,
      scales: {
        x: { time: !fixed, range: (_u, lo, hi) => this.xRange ?? [lo, hi] },
        y: { auto: true },
      },
      series: [
        {
          label: fixed ? "t from trigger" : "Time",
          value: (_u, v) => (v == null ? "--" : fixed ? `${(v * 1e3).toPrecision(6)} ms` : clockTime(v)),
        },
        // the lines are drawn by drawLines (the data is already one point a pixel at most)
        ...shortLabels(this.cfg.paths).map((label, i) => ({
          label,
          stroke: COLORS[i % COLORS.length],
          width: 1,
          points: { show: false },
          paths: () => null,
        })),
      ],
      axes: [
        {
          stroke: "#5f6b76",
          grid: { stroke: "#eef1f4" },
          ...(fixed ? { label: "s from the trigger", labelSize: 20 } : {}),
        },
        { stroke: "#5f6b76", size: 64, grid: { stroke: "#eef1f4" } },
      ],
      cursor: { drag: { x: true, y: false, setScale: false }, bind: { dblclick: () => null }, points: { show: false } },
      legend: { live: true },
      hooks: { setSelect: [(u) => this.onSelect(u)], draw: [drawLines, (u) => drawMarks(u, this.marks)] },
    };
    const u = new uPlot(opts, [[], ...this.cfg.paths.map(() => [])], this.host);
    u.over.addEventListener("dblclick", () => this.unzoom());
    return u;
  }

  /** Draws if something changed and `may`; returns the points drawn, -1 when it did not draw. */
  frame(may = true): number {
    this.updateInfo();
    if (!this.dirty || !may) return -1;
    this.dirty = false;
    const v = this.visible();
    if (this.cfg.mode === "xy") return this.drawXY(v);
    if (!this.chart) return -1;
    const off = this.xOffset;
    const d = this.draw;
    clearDraw(d, this.cfg.paths.length);
    let points = 0;
    if (v) {
      const [t0, t1] = v.range;
      if (this.frozen) {
        const [i0, i1] = v.src.range(t0, t1);
        decimateRange(v.src, i0, i1, bucketSize(i1 - i0, this.width), off, d);
      } else {
        const per = this.periodS ?? 1e-3;
        const size = bucketSize(Math.ceil(this.cfg.windowS / per), this.width);
        if (!this.live || this.live.size !== size || this.live.channels !== this.cfg.paths.length)
          this.live = new LiveDecimator(size, v.src.capacity, this.cfg.paths.length);
        this.live.update(v.src);
        this.live.output(t0, t1, off, d);
      }
      points = d.x.length * this.cfg.paths.length;
      this.xRange = [t0 + off, t1 + off];
    }
    this.chart.setData([d.x, ...d.ys] as uPlot.AlignedData);
    return points;
  }

  private drawXY(v: { src: SampleRing; range: [number, number] } | null): number {
    if (!this.xy) return -1;
    const [px, py] = this.cfg.xy;
    const cx = px ? this.cfg.paths.indexOf(px) : -1;
    const cy = py ? this.cfg.paths.indexOf(py) : -1;
    let i0 = 0,
      i1 = 0;
    if (v) [i0, i1] = v.src.range(v.range[0], v.range[1]);
    return this.xy.draw(v?.src ?? null, i0, i1, cx, cy, px ?? "", py ?? "", this.width, HEIGHT);
  }

  private infoText = "";
  private infoAt = 0;
  /** The line under the chart, at most four times a second (a DOM change costs a layout). */
  private updateInfo(): void {
    const now = performance.now();
    if (now - this.infoAt < 250) return;
    this.infoAt = now;
    const r = this.ring;
    const parts: string[] = [];
    if (this.fixed) {
      const f = this.frozen;
      parts.push(f ? `${f.length} rows` : "nothing to show yet");
      if (f && this.zoom) parts.push("zoomed — double-click for all");
      else if (f) parts.push("drag to zoom");
    } else if (!this.cfg.paths.length) parts.push("add variables with + in the tree or the box above");
    else if (!r || r.length === 0) parts.push("waiting for samples…");
    else {
      const per = this.periodS ?? 0;
      parts.push(`${r.length} samples held (${(r.length * per).toFixed(1)} s at ${(per * 1e3).toPrecision(3)} ms)`);
      if (this.capped) parts.push(`window limited to ${((r.capacity - 1100) * per).toFixed(0)} s by memory`);
      if (r.gapSamples)
        parts.push(
          `seq gaps: ${r.gapSamples} samples (${this.unaccounted} not in the drop counter: resubscriptions, reconnections)`,
        );
      if (r.resets) parts.push(`irpd restarted ${r.resets}×`);
    }
    if (this.frozen && !this.fixed) parts.push(this.paused ? "paused" : "zoomed — double-click or Resume for live");
    const text = parts.join(" · ");
    if (text !== this.infoText) this.info.textContent = this.infoText = text;
  }

  destroy(): void {
    this.unsubscribe?.();
    this.unsubscribe = null;
    this.resize.disconnect();
    this.chart?.destroy();
    this.el.remove();
  }
}
