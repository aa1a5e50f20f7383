// users-page.test.ts -- the Users page in a DOM: the users with their state and last sign-in, a role
// changed from the row's menu, a disable confirmed first, a new user's passwords compared before
// anything is sent, and a reset offered for the others only (one's own goes through the bar).
import { afterEach, describe, expect, it, vi } from "vitest";
import type { AppContext } from "../../src/app/context";
import { usersPage } from "../../src/pages/users";

const USERS = [
  {
    name: "alice",
    role: "admin",
    disabled: false,
    created: "2026-11-26T09:00:00Z",
    created_by: "admin",
    last_sign_in: "2026-11-26T10:00:00.123456Z",
    password_changed: "2026-11-26T09:00:00Z",
    tokens: 0,
    sessions: 1,
  },
  {
    name: "bob",
    role: "operator",
    disabled: false,
    created: "2026-11-26T09:00:00Z",
    created_by: "alice",
    last_sign_in: null,
    password_changed: "2026-11-26T09:00:00Z",
    tokens: 2,
    sessions: 0,
  },
];

function mount() {
  const calls: { method: string; path: string; opts: Record<string, unknown> }[] = [];
  const answer =
    (method: string) =>
    async (path: string, opts: Record<string, unknown> = {}) => {
      calls.push({ method, path, opts });
      return { data: method === "GET" ? USERS : {}, response: new Response(null, { status: 200 }) };
    };
  const ctx = {
    api: { GET: answer("GET"), POST: answer("POST"), PATCH: answer("PATCH"), PUT: answer("PUT") },
    session: { name: "alice", role: "admin", csrf: "c" },
    can: () => true,
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  usersPage(root, ctx);
  return { root, calls };
}

const flush = async () => {
  for (let i = 0; i < 10; i++) await Promise.resolve();
};
const q = <T extends HTMLElement = HTMLElement>(root: HTMLElement, testid: string) =>
  root.querySelector<T>(`[data-testid="${testid}"]`);

afterEach(() => vi.unstubAllGlobals());

describe("the Users page", () => {
  it("lists the users with their state and last sign-in, and no reset of one's own password", async () => {
    const { root } = mount();
    await flush();
    expect(q(root, "state-bob")?.textContent).toBe("enabled");
    expect(q(root, "last-sign-in-bob")?.textContent).toBe("never");
    expect(q(root, "last-sign-in-alice")?.textContent).toBe("2026-11-26 10:00:00 UTC");
    expect(q(root, "reset-bob")).not.toBeNull();
    expect(q(root, "reset-alice")).toBeNull();
  });

  it("changes a role from the row's menu", async () => {
    const { root, calls } = mount();
    await flush();
    const role = q<HTMLSelectElement>(root, "role-bob")!;
    role.value = "viewer";
    role.dispatchEvent(new Event("change"));
    await flush();
    expect(calls.find((c) => c.method === "PATCH")).toEqual({
      method: "PATCH",
      path: "/api/v1/users/{name}",
      opts: { params: { path: { name: "bob" } }, body: { role: "viewer" } },
    });
  });

  it("disables a user only once confirmed", async () => {
    const { root, calls } = mount();
    await flush();
    vi.stubGlobal("confirm", () => false);
    q(root, "toggle-bob")!.click();
    await flush();
    expect(calls.some((c) => c.method === "PATCH")).toBe(false);
    vi.stubGlobal("confirm", (text: string) => text.includes("2 token(s)"));
    q(root, "toggle-bob")!.click();
    await flush();
    expect(calls.find((c) => c.method === "PATCH")?.opts).toEqual({
      params: { path: { name: "bob" } },
      body: { disabled: true },
    });
  });

  it("compares a new user's two passwords before sending anything", async () => {
    const { root, calls } = mount();
    await flush();
    q<HTMLInputElement>(root, "add-name")!.value = "carol";
    q<HTMLInputElement>(root, "add-password")!.value = "one long password";
    q<HTMLInputElement>(root, "add-again")!.value = "another password";
    q(root, "add-user")!
      .closest("form")!
      .dispatchEvent(new Event("submit", { cancelable: true }));
    await flush();
    expect(calls.some((c) => c.method === "POST")).toBe(false);
    expect(q(root, "users-error")?.textContent).toContain("differ");
    q<HTMLInputElement>(root, "add-again")!.value = "one long password";
    q(root, "add-user")!
      .closest("form")!
      .dispatchEvent(new Event("submit", { cancelable: true }));
    await flush();
    expect(calls.find((c) => c.method === "POST")?.opts).toEqual({
      body: { name: "carol", role: "operator", password: "one long password" },
    });
  });
});
