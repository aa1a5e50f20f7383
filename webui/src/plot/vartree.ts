// vartree.ts -- the variable tree of the variables page: groups open on demand, a search box,
// one row per variable with its type, its value (refreshed by the page), a badge while it is
// forced and, for operators and up, a box to write it or force it, and buttons to unforce it.
import { buildTree, filterTree, type TreeNode, typeText, type VarInfo } from "./paths";

const MAX_ROWS = 400; // leaves drawn at once while searching; refine the search for more
const OPEN_ROWS = 24;

export interface TreeEnv {
  canWrite: boolean;
  plot(path: string): void;
  write(v: VarInfo, text: string, row: LeafRow): void;
  /** the variables page's force and unforce (the scope's picker has no such buttons) */
  force?(v: VarInfo, text: string, row: LeafRow): void;
  unforce?(v: VarInfo, restore: boolean, row: LeafRow): void;
}

export interface LeafRow {
  el: HTMLElement;
  value: HTMLElement;
  error: HTMLElement;
  /** the line under the row shown while irpd holds the variable forced: a badge, who forced it to
   *  what and when, and for operators the unforce buttons */
  forced: HTMLElement;
}

/** Shows a row as forced (`why`: to what, by whom, since when) or not (null). */
export function showForced(row: LeafRow, why: string | null): void {
  const forced = why !== null;
  const text = row.forced.querySelector(".why")!;
  if (row.forced.hidden === !forced && text.textContent === (why ?? "")) return;
  row.forced.hidden = !forced;
  text.textContent = why ?? "";
  row.el.classList.toggle("forced", forced);
}

function esc(s: string): string {
  return s.replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

export class VarTree {
  readonly el: HTMLElement;
  private root: TreeNode;
  private list: HTMLElement;
  private search: HTMLInputElement;
  private open = new Set<string>();
  /** rows on the page now, by path */
  readonly rows = new Map<string, LeafRow>();
  /** rows scrolled into view (the page refreshes only these) */
  readonly visible = new Set<string>();
  private observer: IntersectionObserver | null;

  constructor(
    vars: VarInfo[],
    private env: TreeEnv,
  ) {
    this.root = buildTree(vars);
    // groups start open, breadth first, while that shows no more than OPEN_ROWS rows
    let rows = this.root.children.length;
    const queue = [...this.root.children];
    while (queue.length) {
      const n = queue.shift()!;
      if (!n.children.length) continue;
      if (rows + n.children.length > OPEN_ROWS && rows > 1) break;
      this.open.add(n.id);
      rows += n.children.length;
      queue.push(...n.children);
    }
    this.el = document.createElement("aside");
    this.el.className = "var-tree";
    this.el.innerHTML = `
      <input type="search" placeholder="search variables (words, any order)" data-testid="var-search" />
      <div class="var-count" data-testid="var-count"></div>
      <div class="var-list" data-testid="var-list"></div>`;
    this.search = this.el.querySelector("input")!;
    this.list = this.el.querySelector(".var-list")!;
    this.observer =
      typeof IntersectionObserver === "undefined"
        ? null
        : new IntersectionObserver(
            (entries) => {
              for (const e of entries) {
                const p = (e.target as HTMLElement).dataset.path!;
                if (e.isIntersecting) this.visible.add(p);
                else this.visible.delete(p);
              }
            },
            { root: this.list },
          );
    let pending: ReturnType<typeof setTimeout> | null = null;
    this.search.oninput = () => {
      if (pending) clearTimeout(pending);
      pending = setTimeout(() => this.render(), 120);
    };
    this.render();
  }

  render(): void {
    const q = this.search.value;
    const node = filterTree(this.root, q);
    // what is typed in a write box and not sent yet survives the redraw (a search typed meanwhile)
    const typed = new Map<string, string>();
    for (const [path, r] of this.rows) {
      const v = r.el.querySelector<HTMLInputElement>(".write input")?.value;
      if (v) typed.set(path, v);
    }
    this.observer?.disconnect();
    this.rows.clear();
    this.visible.clear();
    this.list.innerHTML = "";
    const count = this.el.querySelector(".var-count")!;
    if (!node) {
      count.textContent = `no variable matches "${q}"`;
      return;
    }
    const budget = { rows: MAX_ROWS };
    const searching = q.trim() !== "";
    for (const c of node.children) this.renderNode(c, this.list, searching, budget);
    count.textContent = searching
      ? `${node.count} of ${this.root.count} variables match` + (budget.rows < 0 ? ` (first ${MAX_ROWS} shown)` : "")
      : `${this.root.count} variables`;
    if (!this.observer) for (const p of this.rows.keys()) this.visible.add(p);
    for (const [path, v] of typed) {
      const input = this.rows.get(path)?.el.querySelector<HTMLInputElement>(".write input");
      if (input) input.value = v;
    }
  }

  private renderNode(n: TreeNode, into: HTMLElement, searching: boolean, budget: { rows: number }): void {
    if (budget.rows <= 0) {
      budget.rows = -1;
      return;
    }
    if (n.leaf && n.children.length === 0) {
      this.renderLeaf(n, n.leaf, into, budget);
      return;
    }
    const g = document.createElement("div");
    g.className = "grp";
    const open = searching || this.open.has(n.id);
    g.innerHTML = `<div class="grp-head" data-testid="grp-${esc(n.id)}"><span class="tw">${open ? "▾" : "▸"}</span>${esc(n.label)} <span class="n">${n.count}</span></div><div class="kids"></div>`;
    const kids = g.querySelector<HTMLElement>(".kids")!;
    const head = g.querySelector<HTMLElement>(".grp-head")!;
    head.onclick = () => {
      if (this.open.has(n.id) || searching) {
        this.open.delete(n.id);
        if (searching) {
          kids.hidden = !kids.hidden;
          head.querySelector(".tw")!.textContent = kids.hidden ? "▸" : "▾";
          return;
        }
      } else this.open.add(n.id);
      this.render();
    };
    into.appendChild(g);
    if (!open) return;
    if (n.leaf) this.renderLeaf(n, n.leaf, kids, budget);
    for (const c of n.children) this.renderNode(c, kids, searching, budget);
  }

  private renderLeaf(n: TreeNode, v: VarInfo, into: HTMLElement, budget: { rows: number }): void {
    if (budget.rows-- <= 0) {
      budget.rows = -1;
      return;
    }
    const row = document.createElement("div");
    row.className = "leaf";
    row.dataset.testid = `var-${v.path}`;
    row.dataset.path = v.path;
    row.innerHTML = `
      <span class="name" title="${esc(v.path)}">${esc(n.label)}</span>
      <span class="type" title="${esc(typeText(v))}">${esc(typeText(v))}</span>
      <span class="val" data-testid="value-${esc(v.path)}">…</span>
      <button class="plot" data-testid="plotvar-${esc(v.path)}" title="plot in the active panel">+</button>
      ${this.env.canWrite ? `<span class="write"><input data-testid="write-${esc(v.path)}" placeholder="value" size="7" /><button class="set" data-testid="set-${esc(v.path)}" title="write once">set</button><button class="force" data-testid="force-${esc(v.path)}" title="hold this value for every reader until unforced">force</button></span>` : ""}
      <div class="forced-line" data-testid="forced-${esc(v.path)}" hidden><span class="forced-badge">forced</span> <span class="why"></span>${this.env.canWrite ? ` <button class="keep" data-testid="unforce-${esc(v.path)}" title="unforce, keeping the forced value">unforce</button> <button class="restore" data-testid="restore-${esc(v.path)}" title="unforce and write back the value before the force">restore</button>` : ""}</div>
      <div class="werr" data-testid="result-${esc(v.path)}"></div>`;
    const lr: LeafRow = {
      el: row,
      value: row.querySelector(".val")!,
      error: row.querySelector(".werr")!,
      forced: row.querySelector(".forced-line")!,
    };
    row.querySelector<HTMLButtonElement>(".plot")!.onclick = () => this.env.plot(v.path);
    const input = row.querySelector<HTMLInputElement>(".write input");
    if (input) {
      const button = (name: string) => row.querySelector<HTMLButtonElement>(`button.${name}`)!;
      const go = () => this.env.write(v, input.value, lr);
      button("set").onclick = go;
      button("force").onclick = () => this.env.force?.(v, input.value, lr);
      button("keep").onclick = () => this.env.unforce?.(v, false, lr);
      button("restore").onclick = () => this.env.unforce?.(v, true, lr);
      input.onkeydown = (ev) => {
        if (ev.key === "Enter") go();
      };
    }
    into.appendChild(row);
    this.rows.set(v.path, lr);
    this.observer?.observe(row);
  }

  destroy(): void {
    this.observer?.disconnect();
  }
}
