// module-fates-view.ts -- what activating a set online does to the running modules, from irpd's
// check of it (`validation.modules`): kept (the same instance goes on, its state and figures too),
// replaced (its instance stops and a new one of the same name starts afresh), new and removed.
// Each module is on one line: irpd lists a replaced module under started and stopped as well.
import { h } from "./dom";
import type { ModuleFates } from "./types";

export type Fate = "kept" | "replaced" | "new" | "removed";

/** The modules per fate, each once (replaced ones left out of new and removed). */
export function moduleFateRows(m: ModuleFates): { fate: Fate; names: string[] }[] {
  const replaced = new Set(m.replaced);
  return [
    { fate: "kept", names: m.kept },
    { fate: "replaced", names: m.replaced },
    { fate: "new", names: m.started.filter((n) => !replaced.has(n)) },
    { fate: "removed", names: m.stopped.filter((n) => !replaced.has(n)) },
  ];
}

const SAYS: Record<Fate, string> = {
  kept: "kept: go on running, same state",
  replaced: "replaced: stopped, started anew (state afresh)",
  new: "new: started",
  removed: "removed: stopped",
};

/** The modules' fates as a small table; null when irpd gave none (invalid, or only a restart runs it). */
export function renderModuleFates(m: ModuleFates | null | undefined, testid = "plan-modules"): HTMLElement | null {
  if (!m) return null;
  return h(
    "table",
    { class: "ops-kv", "data-testid": testid },
    h(
      "tbody",
      {},
      ...moduleFateRows(m).map((r) =>
        h(
          "tr",
          { "data-fate": r.fate },
          h("th", {}, SAYS[r.fate]),
          h("td", { class: "mono", "data-testid": `${testid}-${r.fate}` }, r.names.length ? r.names.join(", ") : "—"),
        ),
      ),
    ),
  );
}
