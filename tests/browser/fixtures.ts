// fixtures.ts -- what every browser test starts from: the server of global-setup.ts, a signed-in
// page per role, a screenshot helper that keeps the pictures as artifacts.

import { join } from "node:path";
import { test as base, expect, type Page } from "@playwright/test";
import type { Server } from "./server";

export const SHOTS = join(__dirname, "../../build/test-artifacts/browser/screenshots");

export function server(): Server {
  const s = process.env.INDUROP_SERVER;
  if (!s) throw new Error("INDUROP_SERVER is not set: run through playwright.config.ts (global setup)");
  return JSON.parse(s) as Server;
}

/** Signs in through the form with the token of `role` and waits for the shell. */
export async function signIn(page: Page, role: "admin" | "operator" | "viewer", hash = "#/overview"): Promise<void> {
  const s = server();
  await page.goto(`${s.url}/${hash}`);
  await page.getByTestId("token").fill(s.tokens[role]);
  await page.getByTestId("sign-in").click();
  await expect(page.getByTestId("who")).toContainText(role);
}

export async function shot(page: Page, name: string): Promise<void> {
  await page.screenshot({ path: join(SHOTS, `${name}.png`), fullPage: false });
}

/** An API call with a role's token, for checking what the UI did. */
export async function api(
  path: string,
  init: RequestInit = {},
  role: "admin" | "operator" | "viewer" = "admin",
): Promise<Response> {
  const s = server();
  const headers = new Headers(init.headers);
  headers.set("Authorization", `Bearer ${s.tokens[role]}`);
  return fetch(`${s.url}/api/v1${path}`, { ...init, headers });
}

export const test = base;
export { expect };
