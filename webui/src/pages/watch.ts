// watch.ts -- the Watch page (#/watch, docs/programming.md "Watch lists"): the watch lists kept with the
// running set (GET /sets/{id}/watches), the chosen one's variables with their live values refreshed
// every MONITOR_MS through one POST /variables/read, a path added with completion from the layout
// (GET /variables), removed, and the list saved or deleted (operator and above; a viewer watches).
import "../ops/ops.css";
import "../programs/programs.css";
import { unwrap } from "../api/client";
import type { AppContext, Page } from "../app/context";
import { errorText, h, type Poller, poll, setText } from "../ops/dom";
import { DEFAULT_WATCH } from "../programs/value_popover";
import { MONITOR_MS, valueClass, valueText } from "../programs/values";

const NO_SET =
  "no set is active in the set store: watch lists are kept with a set; upload one (Modules page) or activate one";
class WatchView {
  readonly element: HTMLElement;
  private setId = "";
  private paths: string[] = [];
  private select = h("select", { "data-testid": "watch-select" });
  private name = h("input", { "data-testid": "watch-name", value: DEFAULT_WATCH, size: 12 });
  private add = h("input", {
    "data-testid": "watch-add-path",
    list: "watch-leaves",
    size: 40,
    placeholder: "a variable path",
  });
  private leaves = h("datalist", { id: "watch-leaves" });
  private rows = h("tbody", { "data-testid": "watch-rows" });
  private status = h("div", { class: "ops-sub", "data-testid": "watch-status", role: "status" });
  private cells = new Map<string, { value: HTMLElement; type: HTMLElement }>();
  private poller: Poller | null = null;

  constructor(private readonly ctx: AppContext) {
    const can = ctx.can("operator");
    this.select.addEventListener("change", () => void this.choose(this.select.value));
    const addButton = h("button", { "data-testid": "watch-add" }, "Add");
    addButton.addEventListener("click", () => this.addPath());
    this.add.addEventListener("keydown", (e) => {
      if (e.key === "Enter") this.addPath();
    });
    const save = h("button", { "data-testid": "watch-save" }, "Save");
    save.addEventListener("click", () => void this.save());
    const remove = h("button", { "data-testid": "watch-delete" }, "Delete list");
    remove.addEventListener("click", () => void this.deleteList());
    this.element = h(
      "div",
      { class: "ops-page", "data-testid": "watch" },
      h(
        "section",
        { class: "panel ops-panel" },
        h("h3", {}, "Watch lists"),
        h(
          "div",
          { class: "ops-actions" },
          h("label", {}, "list ", this.select),
          " name ",
          this.name,
          can ? save : null,
          can ? remove : null,
        ),
        h("div", { class: "ops-actions" }, this.add, this.leaves, addButton),
        this.status,
        h(
          "table",
          { class: "ops-grid" },
          h(
            "thead",
            {},
            h("tr", {}, h("th", {}, "variable"), h("th", {}, "value"), h("th", {}, "type"), h("th", {}, "")),
          ),
          this.rows,
        ),
      ),
    );
  }

  async load(): Promise<void> {
    try {
      // the set list says which is active (GET /sets/active would answer 404 when none is)
      const active = unwrap(await this.ctx.api.GET("/api/v1/sets")).find((s) => s.active);
      if (!active) {
        setText(this.status, NO_SET);
        return;
      }
      this.setId = active.id;
      const lists = unwrap(
        await this.ctx.api.GET("/api/v1/sets/{set_id}/watches", { params: { path: { set_id: this.setId } } }),
      );
      this.select.replaceChildren(
        h("option", { value: "" }, "(new list)"),
        ...lists.watches.map((w) => h("option", { value: w.name }, w.name)),
      );
      const first = lists.watches[0]?.name ?? "";
      this.select.value = first;
      await this.choose(first);
      const vars = unwrap(await this.ctx.api.GET("/api/v1/variables"));
      this.leaves.replaceChildren(...vars.variables.map((v) => h("option", { value: v.path })));
    } catch (e) {
      setText(this.status, errorText(e));
    }
    this.poller = poll(
      () => this.refresh(),
      MONITOR_MS,
      (e) => setText(this.status, errorText(e)),
      true,
    );
  }

  private async choose(name: string): Promise<void> {
    this.paths = [];
    if (name) {
      const w = unwrap(
        await this.ctx.api.GET("/api/v1/sets/{set_id}/watches/{name}", {
          params: { path: { set_id: this.setId, name } },
        }),
      );
      this.paths = [...(w.config?.paths ?? [])];
      this.name.value = name;
    }
    this.draw();
  }

  private addPath(): void {
    const p = this.add.value.trim();
    if (p && !this.paths.includes(p)) this.paths.push(p);
    this.add.value = "";
    this.draw();
  }

  private draw(): void {
    this.cells.clear();
    const can = this.ctx.can("operator");
    this.rows.replaceChildren(
      ...this.paths.map((p) => {
        const value = h("td", { "data-testid": "watch-value" });
        const type = h("td", { class: "ops-sub" });
        this.cells.set(p, { value, type });
        const drop = h("button", { class: "link", title: `remove ${p}` }, "remove");
        drop.addEventListener("click", () => {
          this.paths = this.paths.filter((x) => x !== p);
          this.draw();
        });
        return h(
          "tr",
          { "data-testid": `watch-row-${p}` },
          h("td", { class: "mono" }, p),
          value,
          type,
          h("td", {}, can ? drop : null),
        );
      }),
    );
    this.poller?.now();
  }

  private async refresh(): Promise<void> {
    if (!this.paths.length) return;
    const r = unwrap(await this.ctx.api.POST("/api/v1/variables/read", { body: { paths: this.paths } }));
    for (const v of r.values) {
      const c = this.cells.get(v.path);
      if (!c) continue;
      setText(c.value, `${valueText(v.value)}${v.forced ? " (forced)" : ""}`);
      c.value.className = valueClass(v.value, v.forced);
      setText(c.type, v.type);
    }
    for (const e of r.errors) {
      const c = this.cells.get(e.path);
      if (c) setText(c.value, e.message);
    }
  }

  private async save(): Promise<void> {
    const name = this.name.value.trim();
    if (!this.setId) {
      setText(this.status, NO_SET);
      return;
    }
    try {
      unwrap(
        await this.ctx.api.PUT("/api/v1/sets/{set_id}/watches/{name}", {
          params: { path: { set_id: this.setId, name } },
          body: { paths: this.paths },
        }),
      );
      setText(this.status, `saved ${name} with set ${this.setId}`);
      if (![...this.select.options].some((o) => o.value === name))
        this.select.append(h("option", { value: name }, name));
      this.select.value = name;
    } catch (e) {
      setText(this.status, errorText(e));
    }
  }

  private async deleteList(): Promise<void> {
    const name = this.select.value;
    if (!name || !this.setId) return;
    try {
      unwrap(
        await this.ctx.api.DELETE("/api/v1/sets/{set_id}/watches/{name}", {
          params: { path: { set_id: this.setId, name } },
        }),
      );
      this.select.querySelector(`option[value="${CSS.escape(name)}"]`)?.remove();
      this.select.value = "";
      await this.choose("");
      setText(this.status, `deleted ${name}`);
    } catch (e) {
      setText(this.status, errorText(e));
    }
  }

  destroy(): void {
    this.poller?.stop();
  }
}

export const watchPage: Page = (root, ctx) => {
  const view = new WatchView(ctx);
  root.append(view.element);
  void view.load();
  return () => view.destroy();
};
