// forces.ts -- the Forces page (#/forces, docs/forcing.md): every variable irpd holds forced, with
// the forced value, the value before, who forced it, since when (local time) and its type, from the
// shell's force feed; for operators and up, unforce keeping the value or restoring the one before,
// and a form to force a path (completion from the layout, the value checked against its type).
import "../ops/ops.css";
import { ApiError, unwrap } from "../api/client";
import type { Page } from "../app/context";
import { type Force, forcedSince } from "../app/force-feed";
import { errorText, h, setText } from "../ops/dom";
import type { VarInfo } from "../plot/paths";
import { formatValue, parseValue } from "../plot/vartypes";

export const forcesPage: Page = (root, ctx) => {
  const operator = ctx.can("operator");
  const info = h("span", { class: "ops-sub", "data-testid": "forces-info" });
  const error = h("div", { class: "ops-error", "data-testid": "forces-error", hidden: true });
  const body = h("tbody", {});
  const empty = h("p", { class: "ops-sub", "data-testid": "forces-empty" }, "No variable is forced.");
  const table = h(
    "table",
    { class: "ops-grid ops-dense", "data-testid": "forces-table" },
    h(
      "thead",
      {},
      h(
        "tr",
        {},
        ...["path", "forced value", "before", "by", "since", "type"].map((t) => h("th", {}, t)),
        operator ? h("th", {}, "unforce") : null,
      ),
    ),
    body,
  );
  let vars = new Map<string, VarInfo>();
  const form = operator ? forceForm() : null;
  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "forces" },
      h(
        "section",
        { class: "panel ops-panel" },
        h("h3", {}, "Forces", info),
        error,
        empty,
        h("div", { class: "ops-scroll wide" }, table),
        operator ? null : h("div", { class: "ops-sub" }, `signed in as ${ctx.session.role}: read only`),
      ),
      form?.element ?? null,
    ),
  );

  const unforce = async (f: Force, restore: boolean) => {
    try {
      ctx.notify(await ctx.forces.unforce(f.path, restore));
    } catch (e) {
      ctx.notify(`unforcing ${f.path}: ${errorText(e)}`, "error");
    }
  };

  const unforceButton = (f: Force, restore: boolean) =>
    h(
      "button",
      {
        "data-testid": `unforce-${restore ? "restore" : "keep"}-${f.path}`,
        title: restore ? "unforce, writing back the value before" : "unforce, leaving the forced value",
        onclick: () => void unforce(f, restore),
      },
      restore ? "restore" : "keep",
    );

  const row = (f: Force) => {
    const type = vars.get(f.path)?.type ?? f.type;
    const cell = (name: string, text: string) => h("td", { "data-testid": `force-${name}-${f.path}` }, text);
    return h(
      "tr",
      { "data-testid": `force-row-${f.path}` },
      cell("path", f.path),
      cell("value", formatValue(f.value, type)),
      cell("before", formatValue(f.before, type)),
      cell("by", f.by),
      cell("since", forcedSince(f)),
      cell("type", f.type),
      operator ? h("td", {}, unforceButton(f, false), " ", unforceButton(f, true)) : null,
    );
  };

  let shown = "";
  const stop = ctx.forces.listen((forces, err) => {
    error.hidden = err === null;
    setText(error, err ? `${err} — retrying; the list shown may be stale` : "");
    const key = JSON.stringify(forces);
    if (key === shown) return; // the rows (and a button under the pointer) stay as they are
    shown = key;
    body.replaceChildren(...forces.map(row));
    empty.hidden = forces.length > 0;
    table.hidden = forces.length === 0;
    setText(info, ` — ${forces.length} active`);
  });

  void (async () => {
    try {
      const r = unwrap(await ctx.api.GET("/api/v1/variables")) as { variables?: VarInfo[] };
      vars = new Map((r.variables ?? []).map((v) => [v.path, v]));
      form?.offer([...vars.keys()]);
    } catch (e) {
      form?.say(`the variables could not be listed: ${errorText(e)}`);
    }
  })();

  /** The form that forces a path to a value, checked against the layout's type before it is sent. */
  function forceForm() {
    const path = h("input", {
      list: "force-paths",
      placeholder: "variable path",
      size: 40,
      "data-testid": "force-path",
    });
    const value = h("input", { placeholder: "value", size: 10, "data-testid": "force-value" });
    const paths = h("datalist", { id: "force-paths" });
    const result = h("div", { class: "ops-sub", "data-testid": "force-result" });
    const say = (text: string, bad = true) => {
      setText(result, text);
      result.classList.toggle("bad", bad);
    };
    const submit = async () => {
      const p = path.value.trim();
      const v = vars.get(p);
      if (!p) return say("type a path");
      if (!v) {
        const members = [...vars.keys()].filter((k) => k.startsWith(`${p}.`) || k.startsWith(`${p}[`));
        return say(
          members.length
            ? `'${p}' is a struct or an array: force one of its members (${members.slice(0, 3).join(", ")}${members.length > 3 ? ", …" : ""})`
            : `no variable '${p}' in the running layout: pick one from the list`,
        );
      }
      const parsed = parseValue(value.value, v.type, v.size);
      if (!parsed.ok) return say(parsed.error);
      say("forcing…", false);
      try {
        say(await ctx.forces.force(p, parsed.value), false);
      } catch (e) {
        say(e instanceof ApiError ? `${e.status}: ${e.message}` : errorText(e));
      }
    };
    const go = h("button", { "data-testid": "force-submit", onclick: () => void submit() }, "force");
    value.addEventListener("keydown", (ev) => {
      if (ev.key === "Enter") void submit();
    });
    const element = h(
      "section",
      { class: "panel ops-panel", "data-testid": "force-form" },
      h("h3", {}, "Force a variable"),
      h("div", {}, path, " = ", value, " ", go, paths),
      result,
      h(
        "div",
        { class: "ops-sub" },
        "A forced variable holds the value for every reader in every period, whatever the modules write, until it is unforced; a write to it is refused.",
      ),
    );
    return {
      element,
      say,
      offer(list: string[]) {
        paths.replaceChildren(...list.map((p) => h("option", { value: p })));
      },
    };
  }

  return () => {
    stop();
  };
};
