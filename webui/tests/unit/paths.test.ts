// paths.test.ts -- the variable tree built from leaf paths, its search, short labels, the type shown.
import { describe, expect, it } from "vitest";
import {
  buildTree,
  filterTree,
  leavesOf,
  matches,
  shortLabels,
  splitPath,
  type TreeNode,
  typeText,
  varTitle,
} from "../../src/plot/paths";

const v = (path: string) => ({ path, type: "double", size: 8 });
const VARS = [
  "PLC_ROBOT.I0",
  "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]",
  "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[1]",
  "PLC_ROBOT.ROBOT_MODULE_STATE.eState",
  "PLC_ROBOT.AXIS_IN[0].position",
  "PLC_ROBOT.AXIS_IN[1].position",
  "grid[1][2]",
].map(v);

const labels = (n: TreeNode) => n.children.map((c) => c.label);

describe("splitPath", () => {
  it("splits on dots and array indices", () => {
    expect(splitPath("PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]")).toEqual([
      "PLC_ROBOT",
      "ROBOT_MODULE_STATE",
      "dCurJoint",
      "[0]",
    ]);
    expect(splitPath("PLC.AXIS_IN[0].position")).toEqual(["PLC", "AXIS_IN", "[0]", "position"]);
    expect(splitPath("grid[1][2]")).toEqual(["grid", "[1]", "[2]"]);
    expect(splitPath("plain")).toEqual(["plain"]);
  });
});

describe("buildTree", () => {
  const root = buildTree(VARS);
  it("groups by dots and indices, in the layout's order, counting the variables below", () => {
    expect(labels(root)).toEqual(["PLC_ROBOT", "grid"]);
    expect(root.count).toBe(7);
    const plc = root.children[0];
    expect(labels(plc)).toEqual(["I0", "ROBOT_MODULE_STATE", "AXIS_IN"]);
    expect(plc.count).toBe(6);
    const state = plc.children[1];
    expect(state.id).toBe("PLC_ROBOT.ROBOT_MODULE_STATE");
    expect(labels(state)).toEqual(["dCurJoint", "eState"]);
    const joint = state.children[0];
    expect(labels(joint)).toEqual(["[0]", "[1]"]);
    expect(joint.children[1].id).toBe("PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[1]");
    expect(joint.children[1].leaf?.path).toBe("PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[1]");
    const axis = plc.children[2];
    expect(labels(axis)).toEqual(["[0]", "[1]"]);
    expect(axis.children[0].id).toBe("PLC_ROBOT.AXIS_IN[0]");
    expect(labels(axis.children[0])).toEqual(["position"]);
    expect(root.children[1].children[0].children[0].id).toBe("grid[1][2]");
  });

  it("gives back every variable, in order", () => {
    expect(leavesOf(root).map((l) => l.path)).toEqual(VARS.map((x) => x.path));
  });
});

describe("search", () => {
  const root = buildTree(VARS);
  it("matches every word, in any order and case", () => {
    expect(matches("PLC_ROBOT.AXIS_IN[0].position", "position axis")).toBe(true);
    expect(matches("PLC_ROBOT.AXIS_IN[0].position", "in[0]")).toBe(true);
    expect(matches("PLC_ROBOT.AXIS_IN[0].position", "velocity")).toBe(false);
    expect(matches("anything", "  ")).toBe(true);
  });

  it("prunes the tree to the matching variables", () => {
    const f = filterTree(root, "curjoint")!;
    expect(f.count).toBe(2);
    expect(leavesOf(f).map((l) => l.path)).toEqual([
      "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]",
      "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[1]",
    ]);
    expect(labels(f)).toEqual(["PLC_ROBOT"]);
    expect(filterTree(root, "nothing-like-this")).toBeNull();
    expect(filterTree(root, "")).toBe(root);
  });
});

describe("shortLabels", () => {
  it("drops the shared prefix but keeps an array's name with its index", () => {
    expect(shortLabels(["A.S.dCurJoint[0]", "A.S.dCurJoint[1]"])).toEqual(["dCurJoint[0]", "dCurJoint[1]"]);
    expect(shortLabels(["A.S.x", "A.T.y"])).toEqual(["S.x", "T.y"]);
    expect(shortLabels(["A.S.dWorldPos[0]"])).toEqual(["S.dWorldPos[0]"]);
    expect(shortLabels(["A.S.x"])).toEqual(["S.x"]);
  });
});

describe("typeText", () => {
  it("shows a Structured Text variable's IEC type beside its C++ type, a .glb one's C++ type alone", () => {
    expect(typeText({ path: "Main.t.ET", type: "int64_t", size: 8, iec_type: "TIME" })).toBe("TIME (int64_t)");
    expect(typeText({ path: "PLC_ROBOT.I0", type: "short", size: 2 })).toBe("short");
    expect(typeText({ path: "PLC_ROBOT.I0", type: "short", size: 2, iec_type: null })).toBe("short");
  });
});

describe("varTitle", () => {
  it("names a chip's variable with its types (the Scope's and the plots' chips), a path unknown to the page alone", () => {
    expect(varTitle("Main.t.ET", { path: "Main.t.ET", type: "int64_t", size: 8, iec_type: "TIME" })).toBe(
      "Main.t.ET: TIME (int64_t)",
    );
    expect(varTitle("PLC_ROBOT.I0", { path: "PLC_ROBOT.I0", type: "short", size: 2 })).toBe("PLC_ROBOT.I0: short");
    expect(varTitle("A: SIG.x", undefined)).toBe("A: SIG.x");
  });
});
