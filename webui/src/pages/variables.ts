// variables.ts -- the variables page: every shared variable in a searchable tree with its value
// (refreshed twice a second while on screen), flagged while forced (docs/forcing.md) and, for
// operators, a box to write it or force it and buttons to unforce it; beside it, plot panels fed
// with every sample from the stream (src/plot/panel.ts).
import "../plot/plot.css";
import { ApiError, unwrap } from "../api/client";
import type { Page } from "../app/context";
import { type Force, forcedSince } from "../app/force-feed";
import { MAX_VARS, type PanelConfig, type PanelEnv, PlotPanel, WINDOWS_S } from "../plot/panel";
import { panelsFromHash } from "../plot/panel-link";
import { type VarInfo, varTitle } from "../plot/paths";
import { Pacer, plotStats, recordFrame } from "../plot/stats";
import { type LeafRow, showForced, VarTree } from "../plot/vartree";
import { formatValue, parseValue } from "../plot/vartypes";

const REFRESH_MS = 500;
const MAX_REFRESH = 60; // values read per refresh at most (the rows on screen)
const PARALLEL = 6;
const STORE = "indurop.plots";

function loadPanels(): PanelConfig[] {
  const linked = panelsFromHash(location.hash);
  if (linked) return linked;
  try {
    const v = JSON.parse(sessionStorage.getItem(STORE) ?? "null");
    if (Array.isArray(v)) return v.filter((c) => c && Array.isArray(c.paths));
  } catch {
    /* a damaged entry: start afresh */
  }
  return [{ paths: [], mode: "time", windowS: 10, xy: [null, null] }];
}

/** What follows a forced variable's badge: to what, by whom, since when (once the feed knows). */
function forcedWhy(f: Force | undefined): string {
  return f ? `to ${String(f.value)} by ${f.by} since ${forcedSince(f)}` : "";
}

export const variablesPage: Page = (root, ctx) => {
  root.innerHTML = `
    <div class="vars-page">
      <div class="tree-host"><p>loading variables…</p></div>
      <div class="plots">
        <div class="plots-bar">
          <button data-testid="add-panel">+ panel</button>
          <span class="drops" data-testid="drop-counter"></span>
          <span class="bad" data-testid="stream-error"></span>
        </div>
        <div class="panels" data-testid="panels"></div>
      </div>
    </div>
    <datalist id="var-paths"></datalist>`;
  const treeHost = root.querySelector<HTMLElement>(".tree-host")!;
  const panelsEl = root.querySelector<HTMLElement>(".panels")!;
  const dropEl = root.querySelector<HTMLElement>("[data-testid=drop-counter]")!;
  const streamErr = root.querySelector<HTMLElement>("[data-testid=stream-error]")!;
  let alive = true;
  let vars = new Map<string, VarInfo>();
  let tree: VarTree | null = null;

  // ---- panels --------------------------------------------------------------------------------
  const stats = plotStats();
  const clock = { offset: null as number | null };
  const panels: PlotPanel[] = [];
  let active: PlotPanel | null = null;
  let nextId = 1;
  const save = () => sessionStorage.setItem(STORE, JSON.stringify(panels.map((p) => p.cfg)));
  const activate = (p: PlotPanel | null) => {
    active = p;
    for (const q of panels) q.setActive(q === p);
  };
  const env: PanelEnv = {
    stream: ctx.stream,
    stats,
    clock,
    known: (path) => vars.has(path),
    describe: (path) => varTitle(path, vars.get(path)),
    notify: (m, k) => ctx.notify(m, k),
    changed: save,
    remove(p) {
      p.destroy();
      panels.splice(panels.indexOf(p), 1);
      if (active === p) activate(panels[panels.length - 1] ?? null);
      stats.panels = panels.length;
      save();
    },
    activate,
  };
  const addPanel = (cfg?: PanelConfig) => {
    const c: PanelConfig = cfg ?? { paths: [], mode: "time", windowS: 10, xy: [null, null] };
    if (!WINDOWS_S.includes(c.windowS)) c.windowS = 10;
    if (c.mode !== "xy") c.mode = "time";
    // only known variables reach the stream: one unknown path would make irpd refuse them all
    c.paths = c.paths.filter((p) => vars.has(p)).slice(0, MAX_VARS);
    c.xy = [c.xy?.[0] ?? null, c.xy?.[1] ?? null].map((p) => (p && c.paths.includes(p) ? p : null)) as [
      string | null,
      string | null,
    ];
    const p = new PlotPanel(nextId++, c, env);
    panels.push(p);
    panelsEl.appendChild(p.el);
    activate(p);
    stats.panels = panels.length;
    save();
    return p;
  };
  root.querySelector<HTMLButtonElement>("[data-testid=add-panel]")!.onclick = () => addPanel();

  const plot = (path: string) => {
    (active ?? addPanel()).addPath(path);
  };

  // ---- drawing: one animation frame at a time, every panel in it -------------------------------
  let raf = 0;
  let lastTs: number | null = null;
  const pacer = new Pacer();
  let dropText = "";
  let errText = "";
  const frame = (ts: number) => {
    if (!alive) return;
    const start = performance.now();
    let drew = false;
    let points = 0;
    const may = pacer.mayDraw(lastTs === null ? null : ts - lastTs);
    for (const p of panels) {
      const n = p.frame(may);
      if (n >= 0) {
        drew = true;
        points += n;
      }
    }
    pacer.done(drew);
    stats.drawEvery = pacer.every;
    if (drew) stats.points = points;
    const st = ctx.stream.status;
    stats.uiDropped = st.discarded ?? 0;
    const text =
      `dropped by the agent: ${st.dropped} · discarded by the UI: ${stats.uiDropped}` +
      (st.connected ? "" : " · stream disconnected");
    if (text !== dropText) {
      dropEl.textContent = dropText = text;
      dropEl.classList.toggle("bad", st.dropped > 0 || stats.uiDropped > 0);
    }
    const err = st.error ?? "";
    if (err !== errText) streamErr.textContent = errText = err;
    const prev = lastTs;
    lastTs = ts;
    // uPlot draws in a microtask queued by setData: measure after it
    queueMicrotask(() => recordFrame(stats, ts, prev, performance.now() - start, drew));
    raf = requestAnimationFrame(frame);
  };
  raf = requestAnimationFrame(frame);

  // ---- values and writes -----------------------------------------------------------------------
  const readOne = async (path: string, row: LeafRow) => {
    try {
      const r = unwrap(await ctx.api.GET("/api/v1/variables/{path}", { params: { path: { path } } })) as {
        value: unknown;
        forced?: boolean;
      };
      const v = vars.get(path);
      const text = formatValue(r.value, v?.type ?? "");
      if (row.value.textContent !== text) row.value.textContent = text;
      showForced(row, r.forced ? forcedWhy(ctx.forces.of(path)) : null);
      row.value.classList.remove("bad");
      row.value.title = "";
    } catch (e) {
      row.value.textContent = "?";
      row.value.classList.add("bad");
      row.value.title = e instanceof Error ? e.message : String(e);
    }
  };
  let refreshing = false;
  const refresh = async () => {
    if (!tree || refreshing || document.hidden) return;
    refreshing = true;
    try {
      const todo = [...tree.visible].slice(0, MAX_REFRESH);
      let next = 0;
      const worker = async () => {
        while (alive && next < todo.length) {
          const path = todo[next++];
          const row = tree?.rows.get(path);
          if (row) await readOne(path, row);
        }
      };
      await Promise.all(Array.from({ length: PARALLEL }, worker));
    } finally {
      refreshing = false;
    }
  };
  const timer = setInterval(() => void refresh(), REFRESH_MS);

  const write = async (v: VarInfo, text: string, row: LeafRow) => {
    const parsed = parseValue(text, v.type, v.size);
    row.error.classList.remove("good");
    if (!parsed.ok) {
      row.error.textContent = parsed.error;
      return;
    }
    row.error.textContent = "writing…";
    try {
      unwrap(
        await ctx.api.PUT("/api/v1/variables/{path}", {
          params: { path: { path: v.path } },
          body: { value: parsed.value },
        }),
      );
      row.error.textContent = `wrote ${String(parsed.value)}`;
      row.error.classList.add("good");
      void readOne(v.path, row);
    } catch (e) {
      const msg = e instanceof ApiError ? `${e.status}: ${e.message}` : String(e);
      row.error.textContent = msg;
      ctx.notify(`writing ${v.path}: ${msg}`, "error");
    }
  };

  /** Sends a change of `v` (force or unforce) and shows its outcome in the row. */
  const change = async (v: VarInfo, row: LeafRow, doing: string, send: () => Promise<string>) => {
    row.error.classList.remove("good");
    row.error.textContent = `${doing}…`;
    try {
      row.error.textContent = await send();
      row.error.classList.add("good");
    } catch (e) {
      const msg = e instanceof ApiError ? `${e.status}: ${e.message}` : String(e);
      row.error.textContent = msg;
      ctx.notify(`${doing} ${v.path}: ${msg}`, "error");
    }
    void readOne(v.path, row);
  };
  const force = (v: VarInfo, text: string, row: LeafRow) => {
    const parsed = parseValue(text, v.type, v.size);
    if (!parsed.ok) {
      row.error.classList.remove("good");
      row.error.textContent = parsed.error;
      return;
    }
    void change(v, row, "forcing", () => ctx.forces.force(v.path, parsed.value));
  };
  const unforce = (v: VarInfo, restore: boolean, row: LeafRow) =>
    void change(v, row, "unforcing", () => ctx.forces.unforce(v.path, restore));
  const stopForces = ctx.forces.listen(() => {
    for (const [path, row] of tree?.rows ?? []) {
      const f = ctx.forces.of(path);
      showForced(row, f ? forcedWhy(f) : null);
    }
  });

  // ---- start -----------------------------------------------------------------------------------
  void (async () => {
    try {
      const r = unwrap(await ctx.api.GET("/api/v1/variables")) as { variables?: VarInfo[] };
      if (!alive) return;
      const list = (r.variables ?? []).filter((v) => v && typeof v.path === "string");
      vars = new Map(list.map((v) => [v.path, v]));
      root.querySelector("#var-paths")!.innerHTML = list
        .map((v) => `<option value="${v.path.replace(/"/g, "&quot;")}"></option>`)
        .join("");
      tree = new VarTree(list, {
        canWrite: ctx.can("operator"),
        plot,
        write: (v, t, row) => void write(v, t, row),
        force,
        unforce,
      });
      treeHost.innerHTML = "";
      treeHost.appendChild(tree.el);
      for (const c of loadPanels()) addPanel(c);
      if (panels.length === 0) addPanel();
      activate(panels[0]);
      void refresh();
    } catch (e) {
      treeHost.innerHTML = `<p class="bad" data-testid="var-error"></p>`;
      treeHost.querySelector("p")!.textContent = e instanceof ApiError ? `${e.status}: ${e.message}` : String(e);
    }
  })();

  return () => {
    alive = false;
    stopForces();
    cancelAnimationFrame(raf);
    clearInterval(timer);
    tree?.destroy();
    for (const p of panels) p.destroy();
    panels.length = 0;
  };
};
