// paths.ts -- the variable tree: leaf paths of the layout ("PLC.AXIS_IN[0].position") grouped by
// their dots and array indices, and the search filter over it.

export interface VarInfo {
  path: string;
  type: string;
  size: number;
  /** the IEC 61131-3 type of a Structured Text variable (GET /variables' iec_type) */
  iec_type?: string | null;
}

/** A variable's type as the UI shows it: the IEC type beside the C++ one for a Structured Text
 *  variable ("TIME (int64_t)"), the C++ type alone for a .glb one. */
export function typeText(v: VarInfo): string {
  return v.iec_type ? `${v.iec_type} (${v.type})` : v.type;
}

/** A variable's tooltip (the Scope's and the plots' chips): its path and type, "Main.t.ET: TIME
 *  (int64_t)"; the path alone for a path the page does not know. */
export function varTitle(path: string, v: VarInfo | undefined): string {
  return v ? `${path}: ${typeText(v)}` : path;
}

export interface TreeNode {
  /** this node's own segment: a member name, or an index written "[3]" */
  label: string;
  /** the path of this node ("" for the root); for a leaf, the variable's path */
  id: string;
  children: TreeNode[];
  /** the variable, when this node is one */
  leaf?: VarInfo;
  /** variables at and below this node */
  count: number;
}

/** "a.b[0][2].c" → ["a", "b", "[0]", "[2]", "c"] */
export function splitPath(path: string): string[] {
  const out: string[] = [];
  let cur = "";
  for (let i = 0; i < path.length; i++) {
    const ch = path[i];
    if (ch === ".") {
      if (cur) out.push(cur);
      cur = "";
    } else if (ch === "[") {
      if (cur) out.push(cur);
      const end = path.indexOf("]", i);
      if (end < 0) {
        cur = path.slice(i);
        break;
      }
      out.push(path.slice(i, end + 1));
      cur = "";
      i = end;
    } else {
      cur += ch;
    }
  }
  if (cur) out.push(cur);
  return out;
}

function joinSegment(prefix: string, seg: string): string {
  if (!prefix) return seg;
  return seg.startsWith("[") ? prefix + seg : `${prefix}.${seg}`;
}

/** Groups the variables into a tree, in the layout's order. */
export function buildTree(vars: readonly VarInfo[]): TreeNode {
  const root: TreeNode = { label: "", id: "", children: [], count: 0 };
  const index = new Map<string, TreeNode>([["", root]]);
  for (const v of vars) {
    let node = root;
    node.count++;
    for (const seg of splitPath(v.path)) {
      const id = joinSegment(node.id, seg);
      let child = index.get(id);
      if (!child) {
        child = { label: seg, id, children: [], count: 0 };
        index.set(id, child);
        node.children.push(child);
      }
      child.count++;
      node = child;
    }
    node.leaf = v;
  }
  return root;
}

/** Whether `path` matches the search: every whitespace-separated term appears in it (any case). */
export function matches(path: string, query: string): boolean {
  const p = path.toLowerCase();
  for (const term of query.toLowerCase().split(/\s+/)) if (term && !p.includes(term)) return false;
  return true;
}

/** A copy of the tree holding only the variables that match `query` (null when none does). */
export function filterTree(node: TreeNode, query: string): TreeNode | null {
  if (!query.trim()) return node;
  const children: TreeNode[] = [];
  let count = 0;
  for (const c of node.children) {
    const f = filterTree(c, query);
    if (f) {
      children.push(f);
      count += f.count;
    }
  }
  const leaf = node.leaf && matches(node.leaf.path, query) ? node.leaf : undefined;
  if (leaf) count++;
  if (!leaf && children.length === 0) return null;
  return { ...node, children, leaf, count };
}

/** Every variable below `node`, in order. */
export function leavesOf(node: TreeNode, out: VarInfo[] = []): VarInfo[] {
  if (node.leaf) out.push(node.leaf);
  for (const c of node.children) leavesOf(c, out);
  return out;
}

/** Labels for a set of paths without the dotted prefix they all share ("a.b.x", "a.b.y" → "x",
 * "y"); a single path keeps its last two segments. */
export function shortLabels(paths: readonly string[]): string[] {
  if (paths.length === 0) return [];
  if (paths.length === 1) {
    const segs = splitPath(paths[0]);
    const keep = segs.length > 1 && segs[segs.length - 1].startsWith("[") ? 3 : 2;
    return [joinAll(segs.slice(-keep))];
  }
  const split = paths.map(splitPath);
  let common = 0;
  while (split.every((s) => s.length > common + 1 && s[common] === split[0][common])) common++;
  // keep the array's name with its index: "dCurJoint[0]", not "[0]"
  while (common > 0 && split.some((s) => s[common].startsWith("["))) common--;
  return split.map((s) => joinAll(s.slice(common)));
}

function joinAll(segs: string[]): string {
  return segs.reduce((acc, s) => joinSegment(acc, s), "");
}
