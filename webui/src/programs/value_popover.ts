// value_popover.ts -- the small popover a click on a monitored value opens (operator and above; a viewer
// gets none): write the value once (PUT /variables/{path}), force it (PUT /forces/{path}), unforce and
// keep or unforce and restore the value before (DELETE /forces/{path}?restore=), and add the variable to
// a watch list of the running set (PUT /sets/{id}/watches/{name}).  irpd checks the value against the
// variable's type and range; its refusal is shown as it is.
import { unwrap } from "../api/client";
import type { AppContext } from "../app/context";
import { errorText, h, setText } from "../ops/dom";
import { type Value, valueText } from "./values";

export const DEFAULT_WATCH = "main"; // the list "Add to watch list" adds to unless another is named

/** A typed value: TRUE/FALSE (or 1/0) for a BOOL, else a number; null with the reason otherwise. */
export function parseTyped(text: string, current: Value): { value: boolean | number } | { error: string } {
  const s = text.trim();
  if (typeof current === "boolean") {
    const l = s.toLowerCase();
    if (l === "true" || l === "1") return { value: true };
    if (l === "false" || l === "0") return { value: false };
    return { error: `a BOOL takes TRUE, FALSE, 1 or 0, not "${s}"` };
  }
  if (!/^[+-]?(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$/i.test(s)) return { error: `type a number, not "${s}"` };
  return { value: Number(s) };
}

/** Adds `path` to the watch list `name` of set `setId` (made when it does not exist). */
export async function addToWatch(ctx: AppContext, setId: string, name: string, path: string): Promise<void> {
  const url = "/api/v1/sets/{set_id}/watches/{name}" as const;
  const got = await ctx.api.GET(url, { params: { path: { set_id: setId, name } } });
  const paths = got.response.status === 404 ? [] : (unwrap(got).config?.paths ?? []);
  if (!paths.includes(path)) paths.push(path);
  unwrap(await ctx.api.PUT(url, { params: { path: { set_id: setId, name } }, body: { paths } }));
}

export class ValuePopover {
  readonly element = h("div", { class: "st-popover panel", "data-testid": "st-popover", hidden: true });
  private onDocClick = (e: MouseEvent) => {
    if (!this.element.hidden && !e.composedPath().includes(this.element)) this.close();
  };

  constructor(
    private readonly ctx: AppContext,
    private readonly setId: () => string,
    private readonly changed: () => void,
  ) {
    document.addEventListener("mousedown", this.onDocClick);
  }

  open(anchor: HTMLElement, leaf: { path: string; type: string | null; value: Value }): void {
    const input = h("input", {
      "data-testid": "st-pop-value",
      value: leaf.value === null || leaf.value === undefined ? "" : valueText(leaf.value),
      size: 10,
    });
    const list = h("input", { "data-testid": "st-pop-list", value: DEFAULT_WATCH, size: 8, title: "watch list" });
    const status = h("div", { class: "ops-sub", "data-testid": "st-pop-status", role: "status" });
    const act = (label: string, id: string, fn: () => Promise<unknown>) =>
      h(
        "button",
        {
          "data-testid": id,
          onclick: async () => {
            setText(status, `${label}…`);
            try {
              await fn();
              setText(status, `${label}: done`);
              this.changed();
            } catch (e) {
              setText(status, errorText(e));
            }
          },
        },
        label,
      );
    const typed = () => {
      const p = parseTyped(input.value, leaf.value);
      if ("error" in p) throw new Error(p.error);
      return p.value;
    };
    const path = { path: { path: leaf.path } };
    this.element.replaceChildren(
      h("div", { class: "mono" }, leaf.path, leaf.type ? ` : ${leaf.type}` : ""),
      h("div", {}, input),
      h(
        "div",
        { class: "ops-actions" },
        act("Write", "st-pop-write", async () =>
          unwrap(await this.ctx.api.PUT("/api/v1/variables/{path}", { params: path, body: { value: typed() } })),
        ),
        act("Force", "st-pop-force", async () =>
          unwrap(await this.ctx.api.PUT("/api/v1/forces/{path}", { params: path, body: { value: typed() } })),
        ),
        act("Unforce (keep)", "st-pop-unforce", async () =>
          unwrap(
            await this.ctx.api.DELETE("/api/v1/forces/{path}", { params: { ...path, query: { restore: false } } }),
          ),
        ),
        act("Unforce (restore)", "st-pop-restore", async () =>
          unwrap(await this.ctx.api.DELETE("/api/v1/forces/{path}", { params: { ...path, query: { restore: true } } })),
        ),
      ),
      h(
        "div",
        { class: "ops-actions" },
        act("Add to watch list", "st-pop-watch", () =>
          addToWatch(this.ctx, this.setId(), list.value.trim(), leaf.path),
        ),
        list,
      ),
      status,
    );
    const r = anchor.getBoundingClientRect();
    this.element.hidden = false;
    const left = Math.max(0, Math.min(r.left, document.documentElement.clientWidth - this.element.offsetWidth - 8));
    this.element.style.left = `${Math.round(left + window.scrollX)}px`; // within the window, never past its edge
    this.element.style.top = `${Math.round(r.bottom + window.scrollY + 4)}px`;
    input.focus();
    input.select();
  }

  close(): void {
    this.element.hidden = true;
  }

  destroy(): void {
    document.removeEventListener("mousedown", this.onDocClick);
    this.element.remove();
  }
}
