// programs.ts -- the Programs page (docs/programming.md): the running set's Structured Text files and
// the POUs in each; a file opens in the ST editor (src/programs/st_editor.ts: errors as you type from
// POST /programs/check, completion, hover, folding); Check makes the new set from the running one with
// the file replaced (POST /programs/apply) and shows irpd's dry run with its Activate button
// (ops/activation-review.ts); once activated the editor shows the running version.  Below: the file's
// history across sets, the diff of a version with the running one, and Roll back.  Monitor shows the
// running version read-only with the live values in the code (programs/st_monitor.ts); a click on a
// value opens write / force / unforce / add to watch list (programs/value_popover.ts, operator and
// above).  Read-only for a viewer; checking and applying an edit needs an admin (as an upload),
// activating an operator.  A PLCopen XML file's LD, FBD and SFC POUs open in the live view instead
// (programs/diagram_view.ts: the diagram drawn from the file; with Monitor, power flow and values from
// POST /programs/diagram/monitor).
import "../ops/ops.css";
import "../programs/programs.css";
import { unwrap } from "../api/client";
import type { components } from "../api/schema";
import type { AppContext, Page } from "../app/context";
import { ActivationReview } from "../ops/activation-review";
import { errorText, h, type Poller, poll, setText } from "../ops/dom";
import { problemList } from "../ops/problems-view";
import { renderSwapReport } from "../ops/swap-report-view";
import type { SwapReport } from "../ops/types";
import { formatTime } from "../ops/units";
import { type Diagram, type DiagramMonitorAnswer, DiagramView } from "../programs/diagram_view";
import type { CheckResult, StEditor } from "../programs/st_editor";
import type { Monitor } from "../programs/st_monitor";
import { diffLines } from "../programs/st_view";
import { ValuePopover } from "../programs/value_popover";
import { MONITOR_MS } from "../programs/values";

type S = components["schemas"];
const MONITORING = "monitoring the running version (read-only)";
const GRAPHICAL = ["LD", "FBD", "SFC"];

class ProgramsView {
  readonly element: HTMLElement;
  private files = h("ul", { class: "st-files", "data-testid": "st-files" });
  private title = h("span", { class: "mono", "data-testid": "st-title" });
  private status = h("span", { class: "ops-sub", "data-testid": "st-status", role: "status" });
  private host = h("div", { class: "st-editor", "data-testid": "st-editor" });
  private diagramHost = h("div", { class: "pl-view", "data-testid": "pl-view", hidden: true });
  private diagram: { view: DiagramView; path: string; pou: string; poller: Poller | null } | null = null;
  private errors = h("div", { class: "st-errors", "data-testid": "st-errors" });
  private error = h("div", { class: "ops-error", "data-testid": "st-error", hidden: true, role: "alert" });
  private review = h("div", { "data-testid": "st-review", hidden: true });
  private report = h("div", { "data-testid": "st-report", hidden: true });
  private history = h("tbody", { "data-testid": "st-history" });
  private diff = h("pre", { class: "st-diff", "data-testid": "st-diff", hidden: true });
  private checkButton = h("button", { "data-testid": "st-check", disabled: true }, "Check…");
  private revertButton = h("button", { "data-testid": "st-revert", disabled: true }, "Revert");
  private monitorButton = h("button", { "data-testid": "st-monitor", "aria-pressed": "false" }, "Monitor");
  private monitorNote = h("span", { class: "ops-sub", "data-testid": "st-monitor-note", role: "status" });
  private monitor: Monitor | null = null;
  private popover: ValuePopover | null = null;
  private editor: StEditor | null = null;
  private setId = "";
  private path = "";
  private stored = "";
  private activation: ActivationReview | null = null;

  constructor(private readonly ctx: AppContext) {
    const canEdit = ctx.can("admin");
    const rollback = h("button", { "data-testid": "st-rollback" }, "Roll back");
    rollback.addEventListener("click", () => void this.rollback());
    this.checkButton.addEventListener("click", () => void this.check());
    this.revertButton.addEventListener("click", () => void this.open(this.path));
    this.monitorButton.addEventListener("click", () => void this.toggleMonitor());
    if (ctx.can("operator")) {
      this.popover = new ValuePopover(
        ctx,
        () => this.setId,
        () => {},
      );
      document.body.append(this.popover.element);
    }
    this.element = h(
      "div",
      { class: "ops-page st-page", "data-testid": "programs" },
      h("section", { class: "panel ops-panel st-side" }, h("h3", {}, "Programs"), this.files),
      h(
        "section",
        { class: "panel ops-panel st-main" },
        h("h3", {}, this.title, " ", this.status),
        canEdit
          ? h(
              "div",
              { class: "ops-actions" },
              this.checkButton,
              this.revertButton,
              this.monitorButton,
              this.monitorNote,
            )
          : h(
              "div",
              { class: "ops-actions" },
              this.monitorButton,
              h("span", { class: "ops-sub" }, `signed in as ${ctx.session.role}: read only`),
              this.monitorNote,
            ),
        this.error,
        this.host,
        this.diagramHost,
        this.errors,
        this.review,
        this.report,
      ),
      h(
        "section",
        { class: "panel ops-panel st-history-panel" },
        h("h3", {}, "History"),
        ctx.can("operator") ? h("div", { class: "ops-actions" }, rollback) : null,
        h(
          "table",
          { class: "ops-grid" },
          h("thead", {}, h("tr", {}, h("th", {}, "set"), h("th", {}, "created"), h("th", {}, "by"), h("th", {}, ""))),
          this.history,
        ),
        this.diff,
      ),
    );
  }

  private fail(e: unknown): void {
    this.error.hidden = false;
    setText(this.error, errorText(e));
  }

  /** The running set's files; opens `path` (or the first file). */
  async load(path = this.path): Promise<void> {
    this.error.hidden = true;
    let list: S["ProgramList"];
    try {
      list = unwrap(await this.ctx.api.GET("/api/v1/programs"));
    } catch (e) {
      this.fail(e);
      return;
    }
    if (!list.set_id) {
      setText(this.status, "no set is active in the set store: upload one (Modules page) or activate one");
      return;
    }
    this.setId = list.set_id;
    this.files.replaceChildren(
      ...list.files.map((f) =>
        h(
          "li",
          { "data-testid": `st-file-${f.path}` },
          h(
            "button",
            {
              class: "link mono",
              onclick: () => {
                const first = f.pous.find((p) => GRAPHICAL.includes(p.language ?? "")) ?? f.pous[0];
                void (f.plcopen ? first && this.openDiagram(f.path, first.name) : this.open(f.path));
              },
            },
            f.path,
          ),
          h(
            "ul",
            {},
            ...f.pous.map((p) =>
              h(
                "li",
                {},
                h(
                  "button",
                  {
                    class: "link",
                    "data-testid": `st-pou-${p.name}`,
                    onclick: () => void (f.plcopen ? this.openDiagram(f.path, p.name) : this.show(f.path, p.line)),
                  },
                  `${p.kind} ${p.name}`,
                ),
                h("span", { class: "ops-sub" }, p.language ? ` (${p.language})` : ` :${p.line}`),
              ),
            ),
          ),
        ),
      ),
    );
    const st = list.files.filter((f) => !f.plcopen);
    const first = st.find((f) => f.path === path)?.path ?? st[0]?.path;
    if (this.diagram) await this.openDiagram(this.diagram.path, this.diagram.pou);
    else if (first) await this.open(first);
    else setText(this.status, "the running set has no Structured Text");
  }

  /** Shows a line of a file, opening the file unless it is the one in the editor (edits kept). */
  async show(path: string, line: number): Promise<void> {
    if (path !== this.path || !this.editor) await this.open(path);
    this.editor?.goTo(line);
  }

  /** Monitor on: the running version, read-only, with live values (an edit must be applied or reverted
   * first); off: the editor as before. */
  private async toggleMonitor(): Promise<void> {
    if (this.diagram) {
      const on = this.diagram.poller === null;
      this.monitorButton.setAttribute("aria-pressed", String(on));
      setText(this.monitorNote, on ? MONITORING : "");
      if (on) this.startDiagramMonitor();
      else this.stopDiagramMonitor();
      return;
    }
    if (this.monitor) {
      this.monitor.stop();
      this.monitor = null;
      this.popover?.close();
      this.monitorButton.setAttribute("aria-pressed", "false");
      setText(this.monitorNote, "");
      await this.open(this.path);
      return;
    }
    if (this.editor && this.editor.text() !== this.stored) {
      setText(
        this.monitorNote,
        "the file is modified: apply it (Check…) or Revert it first; the monitor shows the running version",
      );
      return;
    }
    this.monitorButton.setAttribute("aria-pressed", "true");
    setText(this.monitorNote, MONITORING);
    await this.open(this.path, true);
  }

  /** Opens POU `pou` of the running set's PLCopen XML file `path` in the live view (an ST or IL body:
   * its text, read-only); Monitor goes on if it was on. */
  async openDiagram(path: string, pou: string): Promise<void> {
    let d: Diagram;
    try {
      d = unwrap(await this.ctx.api.GET("/api/v1/programs/diagram", { params: { query: { path, pou } } }));
    } catch (e) {
      this.fail(e);
      return;
    }
    const monitoring = this.monitor !== null || this.diagram?.poller != null;
    this.closeDiagram();
    this.monitor?.stop();
    this.monitor = null;
    this.editor?.destroy();
    this.editor = null;
    this.path = path;
    this.setId = d.set_id;
    this.host.hidden = true;
    this.diagramHost.hidden = false;
    this.errors.replaceChildren();
    this.checkButton.disabled = true;
    this.revertButton.disabled = true;
    setText(this.title, `${path}: ${d.kind} ${d.pou} (${d.language ?? "?"}) — set ${d.set_id}`);
    setText(this.status, "read-only");
    const view = new DiagramView(d);
    this.diagramHost.replaceChildren(
      GRAPHICAL.includes(d.language ?? "") ? view.element : h("pre", { class: "pl-text-body" }, d.text ?? ""),
    );
    this.diagram = { view, path, pou, poller: null };
    if (monitoring) this.startDiagramMonitor();
    await this.loadHistory();
  }

  private startDiagramMonitor(): void {
    const d = this.diagram;
    if (!d) return;
    const { path, pou, view } = d;
    const set = this.setId;
    d.poller = poll(
      async () => {
        const answer: DiagramMonitorAnswer = unwrap(
          await this.ctx.api.POST("/api/v1/programs/diagram/monitor", { body: { path, pou, set } }),
        );
        if (this.diagram?.view !== view) return;
        view.show(answer);
        setText(this.monitorNote, MONITORING); // after an error, once it answers again
      },
      MONITOR_MS,
      (e) => setText(this.monitorNote, `monitor: ${errorText(e)}`),
      true,
    );
    this.monitorButton.setAttribute("aria-pressed", "true");
    setText(this.monitorNote, MONITORING);
  }

  private stopDiagramMonitor(): void {
    this.diagram?.poller?.stop();
    if (this.diagram) this.diagram.poller = null;
    this.diagram?.view.show(null);
  }

  private closeDiagram(): void {
    this.stopDiagramMonitor();
    this.diagram = null;
    this.diagramHost.replaceChildren();
    this.diagramHost.hidden = true;
    this.host.hidden = false;
  }

  /** Opens a file of the running set in the editor (with `monitoring`: read-only, with live values). */
  async open(path: string, monitoring = this.monitor !== null || this.diagram?.poller != null): Promise<void> {
    let src: S["ProgramSource"];
    try {
      src = unwrap(await this.ctx.api.GET("/api/v1/programs/source", { params: { query: { path } } }));
    } catch (e) {
      this.fail(e);
      return;
    }
    // CodeMirror is a chunk of its own, loaded when a file is first opened (the other pages never load it)
    const { StEditor: Editor } = await import("../programs/st_editor");
    const mon = await import("../programs/st_monitor");
    this.closeDiagram();
    this.monitor?.stop();
    this.monitor = null;
    this.editor?.destroy();
    this.path = path;
    this.stored = src.source;
    this.review.hidden = true;
    this.activation?.close();
    setText(this.title, `${path} — set ${src.set_id}`);
    setText(this.status, "");
    this.editor = new Editor({
      parent: this.host,
      path,
      text: src.source,
      readOnly: !this.ctx.can("admin") || monitoring,
      extensions: [mon.monitorExtension()],
      check: async (text) =>
        unwrap(await this.ctx.api.POST("/api/v1/programs/check", { body: { path, source: text, set: src.set_id } })),
      onChecked: (r, e) => this.checked(r, e),
      onChange: (text) => {
        this.checkButton.disabled = text === this.stored;
        this.revertButton.disabled = text === this.stored;
        setText(this.status, "checking…");
      },
    });
    this.checkButton.disabled = true;
    this.revertButton.disabled = true;
    if (monitoring) {
      const setId = src.set_id;
      this.monitor = new mon.Monitor(
        this.editor.view,
        async (from_line, to_line, expand) => {
          const answer = unwrap(
            await this.ctx.api.POST("/api/v1/programs/monitor", {
              body: { path, set: setId, from_line, to_line, expand },
            }),
          );
          setText(this.monitorNote, MONITORING); // after an error, once it answers again
          return answer;
        },
        this.popover ? (target, leaf) => this.popover?.open(target, leaf) : null,
        (e) => setText(this.monitorNote, `monitor: ${errorText(e)}`),
      );
    }
    await this.loadHistory();
  }

  private checked(r: CheckResult | null, e?: unknown): void {
    if (!r) {
      setText(this.status, `not checked: ${errorText(e)}`);
      return;
    }
    const n = r.errors.length;
    setText(this.status, n ? `${n} error${n > 1 ? "s" : ""}` : "no errors");
    this.status.dataset.errors = String(n);
    this.errors.replaceChildren(problemList({ errors: [], problems: r.errors })); // as the upload panel lists them
  }

  /** Check: the new set from the running one with this file, and irpd's dry run with Activate. */
  private async check(): Promise<void> {
    if (!this.editor) return;
    this.checkButton.disabled = true;
    this.error.hidden = true;
    this.review.hidden = false;
    this.review.replaceChildren(h("div", { class: "ops-sub" }, "building the set with this file…"));
    try {
      const applied = unwrap(
        await this.ctx.api.POST("/api/v1/programs/apply", {
          body: { path: this.path, source: this.editor.text(), set: this.setId, activate: false, mode: "online" },
        }),
      );
      this.activation?.close();
      this.activation = new ActivationReview(this.ctx, applied.set.id, (title, r) => this.activated(title, r));
      this.review.replaceChildren(this.activation.element);
    } catch (e) {
      this.review.hidden = true;
      this.fail(e);
    } finally {
      this.checkButton.disabled = false;
    }
  }

  private activated(title: string, r: SwapReport): void {
    this.report.hidden = false;
    this.report.replaceChildren(renderSwapReport(title, r));
    void this.load(this.path);
  }

  private async loadHistory(): Promise<void> {
    let hist: S["FileHistory"];
    try {
      hist = unwrap(await this.ctx.api.GET("/api/v1/programs/history", { params: { query: { path: this.path } } }));
    } catch (e) {
      this.fail(e);
      return;
    }
    this.diff.hidden = true;
    this.history.replaceChildren(
      ...hist.versions.map((v) =>
        h(
          "tr",
          { class: v.active ? "active" : "", "data-testid": `st-version-${v.set_id}` },
          h("td", { class: "mono" }, v.set_id, v.active ? " (running)" : ""),
          h("td", {}, formatTime(v.created)),
          h("td", {}, v.by?.name ?? ""),
          h(
            "td",
            {},
            v.active
              ? null
              : h(
                  "button",
                  { class: "link", "data-testid": "st-diff-button", onclick: () => void this.showDiff(v.set_id) },
                  "diff with running",
                ),
          ),
        ),
      ),
    );
  }

  private async showDiff(old: string): Promise<void> {
    try {
      const d = unwrap(
        await this.ctx.api.GET("/api/v1/programs/diff", {
          params: { query: { path: this.path, old, new: this.setId } },
        }),
      );
      this.diff.hidden = false;
      this.diff.replaceChildren(
        ...diffLines(d.diff).map((l) => h("span", { class: `st-diff-${l.kind}` }, `${l.text}\n`)),
      );
    } catch (e) {
      this.fail(e);
    }
  }

  private async rollback(): Promise<void> {
    this.error.hidden = true;
    try {
      const r = unwrap(await this.ctx.api.POST("/api/v1/sets/rollback"));
      this.activated("Rolled back", r as SwapReport);
    } catch (e) {
      this.fail(e);
    }
  }

  destroy(): void {
    this.closeDiagram();
    this.monitor?.stop();
    this.popover?.destroy();
    this.activation?.close();
    this.editor?.destroy();
  }
}

export const programsPage: Page = (root, ctx: AppContext) => {
  const view = new ProgramsView(ctx);
  root.append(view.element);
  void view.load();
  return () => view.destroy();
};
