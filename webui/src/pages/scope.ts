// scope.ts -- the Scope page (docs/webui.md, docs/recorder.md "The Scope page"): set up a triggered
// capture (variables from the tree, a trigger, pre/post, repeat), arm it and watch its state, plot
// its shots in the plot panel (zoom, cursor, x–y; a second shot overlaid on the time from each
// one's trigger), keep trace configurations with the active set and restore them, and list the
// recordings and shots with their downloads.  Viewers look and download; operators act.
import "../ops/ops.css";
import "../plot/plot.css";
import "../scope/scope.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { errorText, h, poll, setText } from "../ops/dom";
import { type PanelEnv, PlotPanel } from "../plot/panel";
import { typeText, type VarInfo, varTitle } from "../plot/paths";
import { emptyStats } from "../plot/stats";
import { VarTree } from "../plot/vartree";
import { type CapturePublic, CapturesView, countsText } from "../scope/captures-view";
import { CaptureFormView } from "../scope/form-view";
import { RecordingsView, type StopKind, startRequest } from "../scope/recordings-view";
import { buildRequest, type CaptureLimits, type CaptureRequest, formOf, isNumeric } from "../scope/request";
import { SavedView, type ScopeConfig, type ScopeList, type ScopeSaved } from "../scope/saved-view";
import { everyFor, plotRows, type Shown, shotTag, summaryText } from "../scope/shots";

const CAPTURES_MS = 500;
const RECORDINGS_MS = 2000;
const LIMITS_MS = 5000;
const ALL_PATHS = "scope-all-paths";
const NUMERIC_PATHS = "scope-numeric-paths";

function panelOf(title: string, testid: string, ...children: (Node | null)[]): HTMLElement {
  return h("section", { class: "panel ops-panel", "data-testid": testid }, h("h3", {}, title), ...children);
}

export const scopePage: Page = (root, ctx) => {
  const operator = ctx.can("operator");
  const cleanups: (() => void)[] = [];
  let alive = true;
  let vars = new Map<string, VarInfo>();
  let limits: CaptureLimits | null = null;
  let basicPeriodNs: number | null = null;
  let captures: CapturePublic[] = [];
  let activeSet: string | null = null;

  // ---- the capture form --------------------------------------------------------------------------
  const formError = h("ul", {
    class: "ops-error scope-errors",
    "data-testid": "form-error",
    role: "alert",
    hidden: true,
  });
  const showErrors = (errors: string[]) => {
    formError.replaceChildren(...errors.map((e) => h("li", {}, e)));
    formError.hidden = errors.length === 0;
  };
  const form = new CaptureFormView({
    maxConditions: () => limits?.max_conditions ?? null,
    lists: { all: ALL_PATHS, numeric: NUMERIC_PATHS },
    describe: (p) => varTitle(p, vars.get(p)),
    changed: () => showErrors([]),
  });
  const env = () => ({ limits, basicPeriodNs, typeOf: (p: string) => vars.get(p)?.type });
  const limitsInfo = h("div", { class: "ops-sub", "data-testid": "capture-limits" }, "");
  const armButton = h("button", { class: "primary", "data-testid": "arm" }, "Arm");
  const formPanel = panelOf(
    "Capture",
    "capture-panel",
    form.el,
    h("div", { class: "ops-actions" }, operator ? armButton : null, limitsInfo),
    formError,
  );

  // ---- the plot ----------------------------------------------------------------------------------
  const panelEnv: PanelEnv = {
    stream: null,
    stats: emptyStats(),
    clock: { offset: null },
    known: () => true,
    describe: (p) => varTitle(p, vars.get(p)),
    notify: (m, k) => ctx.notify(m, k),
    changed: () => {
      if (!applying) view = currentView(); // what the user made of the plot stays for the next shots
    },
    remove: () => {},
    activate: () => {},
  };
  const panel = new PlotPanel(1, { paths: [], mode: "time", windowS: 10, xy: [null, null] }, panelEnv);
  let shown: (Shown & { capture: string; shot: number })[] = [];
  type View = Pick<ScopeConfig, "plotted" | "mode" | "xy">;
  /** how shots are plotted (their channels, the mode, x–y): a restored configuration's, or what the
   * user last made of the plot; applied to every shot plotted after */
  let view: View | null = null;
  let applying = false;
  /** The plot's view now: the channels shown when a single shot shows fewer than it has. */
  const currentView = (): View => {
    const one = shown.length === 1 ? shown[0] : null;
    const all = one?.rows.channels.length ?? 0;
    const plotted = one && panel.cfg.paths.length < all ? [...panel.cfg.paths] : null;
    const mode = panel.cfg.mode;
    return { plotted, mode, xy: mode === "xy" ? [...panel.cfg.xy] : null };
  };
  const shotInfo = h("div", { class: "scope-shots", "data-testid": "shot-info" });
  const follow = h("input", { type: "checkbox", checked: true, "data-testid": "follow-shots" });
  const clearOverlay = h(
    "button",
    { class: "small", "data-testid": "clear-overlay", hidden: true },
    "Remove the overlay",
  );
  const plotError = h("div", { class: "ops-error", "data-testid": "plot-error", hidden: true });
  /** the capture whose new shots are plotted as they come (the one armed here last) */
  let following: string | null = null;

  const drawShown = () => {
    if (!shown.length) return;
    applying = true;
    try {
      panel.showRows(plotRows(shown));
      if (view) {
        panel.setView(view.mode ?? "time", view.xy ?? null);
        const keep = view.plotted ?? [];
        if (shown.length === 1 && keep.some((p) => panel.cfg.paths.includes(p)))
          for (const p of [...panel.cfg.paths]) if (!keep.includes(p)) panel.removePath(p);
      }
    } finally {
      applying = false;
    }
    shotInfo.replaceChildren(
      ...shown.map((s, i) =>
        h(
          "div",
          {
            "data-testid": `shot-info-${i}`,
            "data-trigger-seq": s.rows.summary.trigger_seq,
            "data-pre": s.rows.summary.pre_rows,
            "data-post": s.rows.summary.post_rows,
            "data-drops": s.rows.summary.drops,
          },
          h("b", {}, `${s.tag}: `),
          summaryText(s.rows.summary, s.rows.every),
        ),
      ),
    );
    clearOverlay.hidden = shown.length < 2;
  };
  const plot = async (c: CapturePublic, shot: number, overlay: boolean) => {
    const summary = shot ? c.shots.find((s) => s.shot === shot) : c.shots[c.shots.length - 1];
    if (!summary) return;
    const every = everyFor(summary.rows, c.channels.length);
    try {
      const rows = unwrap(
        await ctx.api.GET("/api/v1/captures/{capture_id}/shots/{shot}", {
          params: { path: { capture_id: c.id, shot: summary.shot }, query: { every } },
        }),
      );
      const entry = { rows, tag: shotTag(c, summary.shot), capture: c.id, shot: summary.shot };
      shown = overlay && shown.length ? [shown[0], entry] : [entry];
      plotError.hidden = true;
      drawShown();
    } catch (e) {
      plotError.hidden = false;
      setText(plotError, `shot #${summary.shot} of ${c.id}: ${errorText(e)}`);
    }
  };
  clearOverlay.addEventListener("click", () => {
    shown = shown.slice(0, 1);
    drawShown();
  });
  const plotPanel = panelOf(
    "Shots",
    "plot-area",
    h(
      "div",
      { class: "ops-actions" },
      h("label", {}, follow, " plot each new shot of the capture armed here"),
      clearOverlay,
    ),
    plotError,
    shotInfo,
    panel.el,
  );

  // ---- the captures ------------------------------------------------------------------------------
  const captureCounts = h("span", { class: "ops-sub", "data-testid": "capture-counts" }, "");
  const listError = h("div", { class: "ops-error", "data-testid": "capture-error", hidden: true, role: "alert" });
  const refreshCaptures = () => capturePoll.now();
  const act = async (what: string, call: () => Promise<unknown>, errorBox = listError) => {
    errorBox.hidden = true;
    try {
      await call();
      ctx.notify(what);
      refreshCaptures();
      return true;
    } catch (e) {
      errorBox.hidden = false;
      setText(errorBox, `${what}: ${errorText(e)}`);
      return false;
    }
  };
  const capturePath = (capture_id: string) => ({ params: { path: { capture_id } } });
  const capturesView = new CapturesView({
    operator,
    act(what, id, call) {
      void act(`${what} ${id}`, async () => {
        if (call === "delete") unwrap(await ctx.api.DELETE("/api/v1/captures/{capture_id}", capturePath(id)));
        else if (call === "arm") unwrap(await ctx.api.POST("/api/v1/captures/{capture_id}/arm", capturePath(id)));
        else if (call === "disarm") unwrap(await ctx.api.POST("/api/v1/captures/{capture_id}/disarm", capturePath(id)));
        else unwrap(await ctx.api.POST("/api/v1/captures/{capture_id}/trigger", capturePath(id)));
        if (call === "arm") following = id;
      });
    },
    plot: (c, shot, overlay) => void plot(c, shot, overlay),
    edit: (c) => form.set(formOf(c.request)),
  });
  const capturesPanel = panelOf("Captures", "captures-panel", listError, capturesView.el);
  capturesPanel.querySelector("h3")!.append(" ", captureCounts);

  /** Arms a capture; the agent's refusal is shown next to the form (a saved one is restored into it first). */
  const arm = async (request: CaptureRequest) => {
    showErrors([]);
    try {
      const c = unwrap(await ctx.api.POST("/api/v1/captures", { body: request }));
      following = c.id;
      ctx.notify(`armed capture ${c.id}`);
      refreshCaptures();
    } catch (e) {
      showErrors([errorText(e)]); // the agent's refusal, next to the form
    }
  };
  armButton.addEventListener("click", () => {
    const built = buildRequest(form.form, env());
    if (!built.ok) showErrors(built.errors);
    else void arm(built.request);
  });

  // ---- trace configurations kept with the active set --------------------------------------------
  const savedError = h("div", { class: "ops-error", "data-testid": "saved-error", hidden: true, role: "alert" });
  const loadSaved = async () => {
    try {
      // the set list says which is active (GET /sets/active would answer 404 when none is)
      const sets = unwrap(await ctx.api.GET("/api/v1/sets"));
      activeSet = sets.find((s) => s.active)?.id ?? null;
      if (!activeSet) {
        saved.show(null, null);
        return;
      }
      const list: ScopeList = unwrap(
        await ctx.api.GET("/api/v1/sets/{set_id}/scopes", { params: { path: { set_id: activeSet } } }),
      );
      if (alive) saved.show(activeSet, list);
    } catch (e) {
      saved.show(null, null, `the saved configurations: ${errorText(e)}`);
    }
  };
  const restore = (s: ScopeSaved) => {
    if (!s.config) return;
    form.set(formOf(s.config.capture));
    view = { plotted: s.config.plotted, mode: s.config.mode, xy: s.config.xy };
    if (shown.length) drawShown();
    saved.name = s.name;
    showErrors([]);
    ctx.notify(`restored ${s.name}`);
  };
  const saved = new SavedView({
    operator,
    restore,
    arm(s) {
      if (!s.config) return;
      restore(s);
      void arm(s.config.capture);
    },
    remove(s) {
      void act(
        `deleted ${s.name}`,
        async () => {
          unwrap(
            await ctx.api.DELETE("/api/v1/sets/{set_id}/scopes/{name}", {
              params: { path: { set_id: s.set_id, name: s.name } },
            }),
          );
          await loadSaved();
        },
        savedError,
      );
    },
    save(name) {
      if (!activeSet) return;
      if (!name) {
        savedError.hidden = false;
        setText(savedError, "give the configuration a name");
        return;
      }
      const built = buildRequest(form.form, env());
      if (!built.ok) {
        showErrors(built.errors);
        return;
      }
      const shows = shown.length ? currentView() : view;
      const body: ScopeConfig = {
        capture: built.request,
        plotted: shows?.plotted ?? null,
        mode: shows?.mode ?? "time",
        xy: shows?.xy ?? null,
      };
      const set_id = activeSet;
      void act(
        `saved ${name} with set ${set_id}`,
        async () => {
          unwrap(
            await ctx.api.PUT("/api/v1/sets/{set_id}/scopes/{name}", { params: { path: { set_id, name } }, body }),
          );
          await loadSaved();
        },
        savedError,
      );
    },
  });
  const savedPanel = panelOf("Trace configurations", "saved-panel", saved.el, savedError);

  // ---- recordings --------------------------------------------------------------------------------
  const recError = h("div", { class: "ops-error", "data-testid": "rec-error", hidden: true, role: "alert" });
  const recordings = new RecordingsView({
    operator,
    stop: (name) =>
      void act(
        `stopped ${name}`,
        async () =>
          unwrap(await ctx.api.POST("/api/v1/recordings/{name}/stop", { params: { path: { name } } })) &&
          recordingPoll.now(),
        recError,
      ),
    remove: (name) =>
      void act(
        `deleted ${name}`,
        async () => {
          unwrap(await ctx.api.DELETE("/api/v1/recordings/{name}", { params: { path: { name } } }));
          recordingPoll.now();
        },
        recError,
      ),
  });
  const recName = h("input", { class: "ops-edit", size: 14, placeholder: "name", "data-testid": "rec-name" });
  const recDecimation = h("input", { class: "ops-edit", size: 4, value: "1", "data-testid": "rec-decimation" });
  const recStop = h(
    "select",
    { class: "ops-edit", "data-testid": "rec-stop-kind" },
    h("option", { value: "manual" }, "until stopped"),
    h("option", { value: "duration" }, "for seconds:"),
    h("option", { value: "size" }, "up to MB:"),
  );
  const recValue = h("input", { class: "ops-edit", size: 6, "data-testid": "rec-stop-value" });
  const recStart = h("button", { "data-testid": "rec-start" }, "Record the capture's variables");
  recStart.addEventListener("click", () => {
    const r = startRequest(
      recName.value,
      form.form.variables,
      recDecimation.value,
      recStop.value as StopKind,
      recValue.value,
    );
    if (!r.ok) {
      recError.hidden = false;
      setText(recError, r.error);
      return;
    }
    void act(
      `recording ${r.body.name}`,
      async () => {
        unwrap(await ctx.api.POST("/api/v1/recordings", { body: r.body }));
        recordingPoll.now();
      },
      recError,
    );
  });
  const recordingsPanel = panelOf(
    "Recordings and shots",
    "recordings-panel",
    operator
      ? h("div", { class: "ops-actions" }, recName, " every ", recDecimation, " rows, ", recStop, recValue, recStart)
      : null,
    recError,
    recordings.el,
  );

  // ---- layout ------------------------------------------------------------------------------------
  const treeHost = h("div", { class: "tree-host" }, h("p", {}, "loading variables…"));
  root.append(
    h(
      "div",
      { class: "vars-page scope-page", "data-testid": "scope-page" },
      treeHost,
      h(
        "div",
        { class: "ops-page" },
        operator
          ? formPanel
          : panelOf(
              "Capture",
              "capture-panel",
              h("p", { class: "ops-sub" }, "Arming captures and recording need the operator role."),
            ),
        savedPanel,
        capturesPanel,
        plotPanel,
        recordingsPanel,
      ),
    ),
    h("datalist", { id: ALL_PATHS }),
    h("datalist", { id: NUMERIC_PATHS }),
  );

  // ---- polling -----------------------------------------------------------------------------------
  let lastFollowed = "";
  const capturePoll = poll(
    async () => {
      const list = unwrap(await ctx.api.GET("/api/v1/captures"));
      if (!alive) return;
      captures = list.captures;
      listError.hidden = true;
      setText(captureCounts, countsText(captures));
      capturesView.show(captures);
      const f = following ? captures.find((c) => c.id === following) : undefined;
      const newest = f?.shots[f.shots.length - 1]?.shot ?? 0;
      // each capture's new shot once (by capture and number: a new capture starts again at #1)
      if (f && follow.checked && newest && `${f.id}#${newest}` !== lastFollowed && shown.length < 2) {
        lastFollowed = `${f.id}#${newest}`;
        await plot(f, newest, false);
      }
    },
    CAPTURES_MS,
    (e) => {
      listError.hidden = false;
      setText(listError, `the captures: ${errorText(e)}`);
    },
  );
  const recordingPoll = poll(
    async () => {
      const list = unwrap(await ctx.api.GET("/api/v1/recordings"));
      if (alive) recordings.show(list);
    },
    RECORDINGS_MS,
    (e) => {
      recError.hidden = false;
      setText(recError, `the recordings: ${errorText(e)}`);
    },
  );
  const limitsPoll = poll(async () => {
    const [l, status] = await Promise.all([ctx.api.GET("/api/v1/captures/limits"), ctx.api.GET("/api/v1/status")]);
    limits = unwrap(l);
    basicPeriodNs = status.response.ok ? (status.data?.basic_period_ns ?? null) : null;
    setText(
      limitsInfo,
      `at most ${limits.max_channels} channels, ${limits.max_conditions} conditions, ` +
        `${limits.max_pre_rows} rows before the trigger (the trace rings' capacity)` +
        (basicPeriodNs ? `, rows of ${basicPeriodNs / 1e6} ms` : ""),
    );
  }, LIMITS_MS);
  cleanups.push(
    () => capturePoll.stop(),
    () => recordingPoll.stop(),
    () => limitsPoll.stop(),
  );

  // ---- drawing: the panel draws at most once an animation frame, when something changed ----------
  let raf = 0;
  const frame = () => {
    if (!alive) return;
    const points = panel.frame(true);
    if (points >= 0) panel.el.dataset.points = String(points);
    raf = requestAnimationFrame(frame);
  };
  raf = requestAnimationFrame(frame);

  // ---- start -------------------------------------------------------------------------------------
  void (async () => {
    try {
      const r = unwrap(await ctx.api.GET("/api/v1/variables")) as { variables?: VarInfo[] };
      if (!alive) return;
      const list = (r.variables ?? []).filter((v) => v && typeof v.path === "string");
      vars = new Map(list.map((v) => [v.path, v]));
      // the picker offers each path with its type: "TIME (int64_t)" beside a Structured Text variable
      const options = (l: VarInfo[]) => l.map((v) => h("option", { value: v.path, label: typeText(v) }));
      root.querySelector(`#${ALL_PATHS}`)!.replaceChildren(...options(list));
      root.querySelector(`#${NUMERIC_PATHS}`)!.replaceChildren(...options(list.filter((v) => isNumeric(v.type))));
      const tree = new VarTree(list, {
        canWrite: false,
        plot: (path) => {
          if (operator) form.addVariable(path);
        },
        write: () => {},
      });
      cleanups.push(() => tree.destroy());
      treeHost.replaceChildren(tree.el);
    } catch (e) {
      treeHost.replaceChildren(h("p", { class: "bad", "data-testid": "var-error" }, errorText(e)));
    }
  })();
  void loadSaved();

  return () => {
    alive = false;
    cancelAnimationFrame(raf);
    for (const c of cleanups) c();
    panel.destroy();
  };
};
