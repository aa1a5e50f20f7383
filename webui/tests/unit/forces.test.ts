// forces.test.ts -- the force banner's words and tooltip, and the Forces page in a DOM: the rows follow
// the force feed, an operator's restore unforces the row's path with restore=true, a value that does
// not fit the variable's type or a struct as a whole is refused before anything is sent, a viewer gets
// no control.
import { describe, expect, it } from "vitest";
import type { AppContext, Role } from "../../src/app/context";
import { bannerText, type Force, ForceFeed, forcesTitle } from "../../src/app/force-feed";
import { forcesPage } from "../../src/pages/forces";
import { fakeApi, flush, q } from "./page-helpers";

const enable: Force = {
  path: "PLC_ROBOT.PLC_IN.Enable",
  value: 1,
  before: 0,
  by: "otto",
  since_ns: Date.UTC(2026, 11, 7, 17, 40) * 1e6,
  type: "short",
};

function mount(role: Role) {
  const { calls, api } = fakeApi((path) =>
    path === "/api/v1/variables"
      ? { variables: [{ path: enable.path, type: "short", size: 2 }] }
      : path === "/api/v1/forces"
        ? { forces: [enable], max_forces: 256 }
        : { force: enable, left: 0, restored: true },
  );
  const ctx = {
    api,
    session: { name: "otto", role, csrf: "c" },
    forces: new ForceFeed(api as unknown as AppContext["api"]),
    can: (r: Role) => (role === "viewer" ? r === "viewer" : true),
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  const unmount = forcesPage(root, ctx);
  return { root, calls, unmount };
}

describe("the force banner", () => {
  it("counts the forces, singular for one, and is empty with none", () => {
    expect(bannerText(0)).toBe("");
    expect(bannerText(1)).toBe("1 force active");
    expect(bannerText(3)).toBe("3 forces active");
  });
  it("names who forced what to which value in its tooltip", () => {
    expect(forcesTitle([enable])).toMatch(/^PLC_ROBOT\.PLC_IN\.Enable = 1 \(forced by otto, .+\)$/);
  });
});

describe("the Forces page", () => {
  it("lists the feed's forces; an operator's restore unforces the row's path with restore=true", async () => {
    const { root, calls, unmount } = mount("operator");
    await flush();
    expect(q(root, `force-value-${enable.path}`)?.textContent).toBe("1");
    expect(q(root, `force-before-${enable.path}`)?.textContent).toBe("0");
    expect(q(root, `force-by-${enable.path}`)?.textContent).toBe("otto");
    q(root, `unforce-restore-${enable.path}`)!.click();
    await flush();
    expect(calls.find((c) => c.method === "DELETE")).toEqual({
      method: "DELETE",
      path: "/api/v1/forces/{path}",
      opts: { params: { path: { path: enable.path }, query: { restore: true } } },
    });
    unmount();
  });

  it("refuses a value of the wrong type, or a struct as a whole, before sending anything", async () => {
    const { root, calls, unmount } = mount("operator");
    await flush();
    (q(root, "force-path") as HTMLInputElement).value = enable.path;
    (q(root, "force-value") as HTMLInputElement).value = "70000";
    q(root, "force-submit")!.click();
    await flush();
    expect(q(root, "force-result")?.textContent).toBe("70000 is out of the range of short: -32768..32767");
    (q(root, "force-path") as HTMLInputElement).value = "PLC_ROBOT.PLC_IN";
    q(root, "force-submit")!.click();
    expect(q(root, "force-result")?.textContent).toBe(
      "'PLC_ROBOT.PLC_IN' is a struct or an array: force one of its members (PLC_ROBOT.PLC_IN.Enable)",
    );
    expect(calls.some((c) => c.method === "PUT")).toBe(false);
    unmount();
  });

  it("shows a viewer the forces and no control", async () => {
    const { root, unmount } = mount("viewer");
    await flush();
    expect(q(root, `force-row-${enable.path}`)).not.toBeNull();
    expect(root.querySelectorAll("button").length).toBe(0);
    expect(q(root, "force-form")).toBeNull();
    unmount();
  });
});
