// alarms-page.test.ts -- the Alarms page in a DOM: the list follows the alarm feed, an operator's
// Acknowledge and Shelve send the alarm's key and body, a viewer gets no buttons, the history is
// asked with the filters, and a shelve form being typed in survives the pushes.
import { describe, expect, it } from "vitest";
import type { AlarmFeed } from "../../src/app/alarm-feed";
import type { AppContext, Role } from "../../src/app/context";
import { type AlarmView, emptyView } from "../../src/ops/alarms";
import { alarmsPage } from "../../src/pages/alarms";
import { alarm, live } from "./alarm-fixtures";

const plc8 = alarm("PLC/8", { text: "drive communication lost", detail: "comm lost: Invalid data", value: 22 });

function mount(role: Role) {
  const calls: { method: string; path: string; opts: Record<string, unknown> }[] = [];
  let listener: ((v: AlarmView, connected: boolean) => void) | null = null;
  const answer =
    (method: string) =>
    async (path: string, opts: Record<string, unknown> = {}) => {
      calls.push({ method, path, opts });
      const data = path.endsWith("/history") ? { transitions: [], total: 0, offset: 0, limit: 50 } : {};
      return { data, response: new Response(null, { status: 200 }) };
    };
  const feed = {
    listen(fn: (v: AlarmView, connected: boolean) => void) {
      listener = fn;
      fn(emptyView(), false);
      return () => {};
    },
  } as unknown as AlarmFeed;
  const ctx = {
    api: { GET: answer("GET"), POST: answer("POST") },
    session: { name: "op", role, csrf: "c" },
    alarms: feed,
    can: (r: Role) => (role === "viewer" ? r === "viewer" : true),
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  alarmsPage(root, ctx);
  return { root, calls, push: (v: AlarmView) => listener!(v, true) };
}

const flush = async () => {
  for (let i = 0; i < 5; i++) await Promise.resolve();
};
const q = (root: HTMLElement, testid: string) => root.querySelector<HTMLElement>(`[data-testid="${testid}"]`);

describe("the Alarms page", () => {
  it("lists the feed's alarms and acknowledges one by its key", async () => {
    const { root, calls, push } = mount("operator");
    push(live([plc8]));
    expect(q(root, "alarm-PLC/8")?.textContent).toContain("drive communication lost");
    expect(q(root, "state-PLC/8")?.textContent).toBe("active, unacknowledged");
    expect(q(root, "alarm-counts")?.textContent).toBe(" — 1 active · 1 unacknowledged");
    q(root, "ack-PLC/8")!.click();
    await flush();
    const ack = calls.find((c) => c.method === "POST");
    expect(ack).toEqual({
      method: "POST",
      path: "/api/v1/alarms/{key}/ack",
      opts: { params: { path: { key: "PLC/8" } } },
    });
  });

  it("shelves with minutes and a reason, and keeps the form through pushes", async () => {
    const { root, calls, push } = mount("operator");
    push(live([plc8]));
    q(root, "shelve-PLC/8")!.click();
    const reason = q(root, "shelve-reason") as HTMLInputElement;
    const confirm = q(root, "shelve-confirm") as HTMLButtonElement;
    expect(confirm.disabled).toBe(true); // no reason yet
    reason.value = "drive swapped";
    reason.dispatchEvent(new Event("input"));
    push(live([{ ...plc8, detail: "again" }])); // a push while typing
    expect(q(root, "shelve-reason")).toBe(reason);
    const minutes = q(root, "shelve-minutes") as HTMLInputElement;
    minutes.value = "15";
    minutes.dispatchEvent(new Event("input"));
    expect(confirm.disabled).toBe(false);
    confirm.click();
    await flush();
    const shelve = calls.find((c) => c.path.endsWith("/shelve"));
    expect(shelve?.opts).toEqual({
      params: { path: { key: "PLC/8" } },
      body: { minutes: 15, reason: "drive swapped" },
    });
  });

  it("gives a viewer no buttons", () => {
    const { root, push } = mount("viewer");
    push(live([plc8]));
    expect(q(root, "alarm-PLC/8")).not.toBeNull();
    expect(root.querySelectorAll("button[data-testid^=ack], button[data-testid^=shelve]").length).toBe(0);
  });

  it("asks for the history with the filters, and refuses a window backwards", async () => {
    const { root, calls } = mount("viewer");
    await flush();
    (q(root, "history-module") as HTMLInputElement).value = "PLC";
    (q(root, "history-severity") as HTMLSelectElement).value = "high";
    q(root, "history-apply")!.click();
    await flush();
    const asked = calls.filter((c) => c.path === "/api/v1/alarms/history").at(-1);
    expect(asked?.opts).toEqual({ params: { query: { module: "PLC", severity: "high", limit: 50, offset: 0 } } });
    (q(root, "history-since") as HTMLInputElement).value = "2026-11-26T09:00";
    (q(root, "history-until") as HTMLInputElement).value = "2026-11-26T08:00";
    q(root, "history-apply")!.click();
    await flush();
    expect(q(root, "history-error")?.hidden).toBe(false);
    expect(q(root, "history-error")?.textContent).toContain("after");
  });
});
