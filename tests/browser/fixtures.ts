// fixtures.ts -- what every browser test starts from: the server of global-setup.ts, signing in
// through the form with a user's name and password, a screenshot helper that keeps the pictures as
// artifacts, and API calls with a role's token for checking what the UI did.

import { join } from "node:path";
import { test as base, expect, type Page } from "@playwright/test";
import type { Role, Server, User } from "./server";

export const SHOTS = join(__dirname, "../../build/test-artifacts/browser/screenshots");

export function server(): Server {
  const s = process.env.INDUROP_SERVER;
  if (!s) throw new Error("INDUROP_SERVER is not set: run through playwright.config.ts (global setup)");
  return JSON.parse(s) as Server;
}

/** Fills the sign-in form (the page shows it) with `user`'s name and password and sends it. */
export async function fillSignIn(page: Page, user: User): Promise<void> {
  await page.getByTestId("user-name").fill(user.name);
  await page.getByTestId("password").fill(user.password);
  await page.getByTestId("sign-in").click();
}

/** Signs in through the form as the user of `role` (of agent `url`) and waits for the shell. */
export async function signIn(
  page: Page,
  role: Role,
  hash = "#/overview",
  s: { url: string; users: Record<Role, User> } = server(),
): Promise<void> {
  await page.goto(`${s.url}/${hash}`);
  await fillSignIn(page, s.users[role]);
  await expect(page.getByTestId("who")).toContainText(role);
}

export async function shot(page: Page, name: string): Promise<void> {
  await page.screenshot({ path: join(SHOTS, `${name}.png`), fullPage: false });
}

/** An API call with a role's token, for checking what the UI did. */
export async function api(path: string, init: RequestInit = {}, role: Role = "admin"): Promise<Response> {
  const s = server();
  const headers = new Headers(init.headers);
  headers.set("Authorization", `Bearer ${s.tokens[role]}`);
  return fetch(`${s.url}/api/v1${path}`, { ...init, headers });
}

export const test = base;
export { expect };
