// users.spec.ts -- people and their passwords in the browser: the first-run page creates the first
// admin with the admin token; an admin adds a user on the Users page, who signs in with a name and
// password and changes it from the bar (the old one is refused afterwards); an admin changes a role,
// disables a user (whose open page is signed out and who can no longer sign in), enables them again
// and resets their password.
import { spawn } from "node:child_process";
import { mkdtempSync, readFileSync } from "node:fs";
import { createServer } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import type { Browser, Page } from "@playwright/test";
import { api, expect, fillSignIn, server, shot, signIn, test } from "./fixtures";
import { ROOT } from "./server";

function uniqueName(prefix: string): string {
  return `${prefix}${Date.now().toString(36)}`;
}

async function addUser(name: string, role: string, password: string): Promise<void> {
  const r = await api("/users", {
    method: "POST",
    body: JSON.stringify({ name, role, password }),
    headers: { "Content-Type": "application/json" },
  });
  expect(r.status, await r.clone().text()).toBe(201);
}

/** A page of its own browser context (its own cookies) signed in as `name`. */
async function signedInAs(browser: Browser, name: string, password: string): Promise<Page> {
  const page = await (await browser.newContext()).newPage();
  await page.goto(`${server().url}/#/overview`);
  await fillSignIn(page, { name, password });
  await expect(page.getByTestId("who")).toContainText(name);
  return page;
}

async function signInFails(browser: Browser, name: string, password: string): Promise<void> {
  const page = await (await browser.newContext()).newPage();
  await page.goto(`${server().url}/`);
  await fillSignIn(page, { name, password });
  await expect(page.getByTestId("signin-error")).toContainText("401");
  await page.context().close();
}

test("an admin adds a user, who signs in and changes their password; only the new one works then", async ({
  page,
  browser,
}) => {
  const name = uniqueName("paula");
  await signIn(page, "admin", "#/users");
  await page.getByTestId("add-name").fill(name);
  await page.getByTestId("add-role").selectOption("operator");
  await page.getByTestId("add-password").fill("first-password-1");
  await page.getByTestId("add-again").fill("first-password-1");
  await page.getByTestId("add-user").click();
  const row = page.getByTestId(`user-row-${name}`);
  await expect(row).toContainText("operator");
  await expect(page.getByTestId(`state-${name}`)).toHaveText("enabled");
  await expect(page.getByTestId(`last-sign-in-${name}`)).toHaveText("never");

  const user = await signedInAs(browser, name, "first-password-1");
  await expect(user.getByTestId("who")).toHaveText(`${name} · operator`);
  await user.getByTestId("change-password").click();
  await user.getByTestId("pw-current").fill("first-password-1");
  await user.getByTestId("pw-new").fill("second-password-2");
  await user.getByTestId("pw-again").fill("second-password-2");
  await shot(user, "change-password");
  await user.getByTestId("pw-save").click();
  await expect(user.getByTestId("notice")).toContainText("password changed");
  await expect(user.getByTestId("password-dialog")).toHaveCount(0);
  await user.getByTestId("sign-out").click();
  await expect(user.getByTestId("signin")).toBeVisible();

  await signInFails(browser, name, "first-password-1");
  const again = await signedInAs(browser, name, "second-password-2");
  await again.context().close();
  await user.context().close();
  await page.reload();
  await expect(page.getByTestId(`last-sign-in-${name}`)).not.toHaveText("never");
  await shot(page, "users");
});

test("an admin changes a role, disables a user (signed out at once, refused afterwards), enables them and resets the password", async ({
  page,
  browser,
}) => {
  const name = uniqueName("quinn");
  await addUser(name, "viewer", "quinn-password-1");
  const user = await signedInAs(browser, name, "quinn-password-1");
  await expect(user.getByTestId("who")).toContainText("viewer");

  await signIn(page, "admin", "#/users");
  await page.getByTestId(`role-${name}`).selectOption("operator");
  await expect(page.getByTestId("notice")).toContainText(`${name}: role operator`);
  await user.reload();
  await expect(user.getByTestId("who")).toContainText("operator");

  page.once("dialog", (d) => d.accept());
  await page.getByTestId(`toggle-${name}`).click();
  await expect(page.getByTestId(`state-${name}`)).toHaveText("disabled");
  // the user's open page: its next request is refused, and it goes back to the sign-in form
  await expect(user.getByTestId("signin")).toBeVisible({ timeout: 15_000 });
  await expect(user.getByTestId("signin-notice")).toContainText("session has ended");
  await signInFails(browser, name, "quinn-password-1");

  await page.getByTestId(`toggle-${name}`).click();
  await expect(page.getByTestId(`state-${name}`)).toHaveText("enabled");
  await page.getByTestId(`reset-${name}`).click();
  await page.getByTestId("reset-password").fill("quinn-reset-password-2");
  await page.getByTestId("reset-again").fill("quinn-reset-password-2");
  await page.getByTestId("reset-save").click();
  await expect(page.getByTestId("notice")).toContainText(`password of ${name} reset`);
  await signInFails(browser, name, "quinn-password-1");
  const back = await signedInAs(browser, name, "quinn-reset-password-2");
  await back.context().close();
  await user.context().close();

  const audit = (await (await api("/audit?limit=200")).json()) as {
    action: string;
    target: string;
    who: { name: string };
  }[];
  const mine = audit.filter((e) => e.target === name).map((e) => e.action);
  expect(mine).toEqual(expect.arrayContaining(["user_add", "user_change", "user_password", "sign_in"]));
  expect(
    audit
      .filter((e) => e.target === name && e.action === "user_change")
      .every((e) => e.who.name === server().users.admin.name),
  ).toBe(true);
});

// ---- the first run: an agent with no user yet (no irpd needed for it) ----------------------------------
async function freePort(): Promise<number> {
  return new Promise((resolve) => {
    const s = createServer().listen(0, "127.0.0.1", () => {
      const port = (s.address() as { port: number }).port;
      s.close(() => resolve(port));
    });
  });
}

test("with no user yet, the first-run page creates the first admin with the admin token and signs in", async ({
  page,
}) => {
  const data = mkdtempSync(join(tmpdir(), "indurop-first-run-"));
  const port = await freePort();
  const agent = spawn(
    join(ROOT, ".venv/bin/python"),
    [
      "-m",
      "indurop_agent",
      "--host",
      "127.0.0.1",
      "--port",
      String(port),
      "--data-dir",
      data,
      "--irpd-socket",
      join(data, "none.sock"),
    ],
    { stdio: "ignore" },
  );
  const url = `http://127.0.0.1:${port}`;
  try {
    for (let i = 0; i < 300; i++) {
      if (
        await fetch(`${url}/api/v1/health`).then(
          (r) => r.ok,
          () => false,
        )
      )
        break;
      await new Promise((r) => setTimeout(r, 100));
    }
    await page.goto(`${url}/`);
    await expect(page.getByTestId("first-run")).toBeVisible();
    await page.getByTestId("admin-token").fill("not-the-token");
    await page.getByTestId("first-name").fill("root-admin");
    await page.getByTestId("first-password").fill("first-admin-password");
    await page.getByTestId("first-password-again").fill("first-admin-password");
    await page.getByTestId("create-admin").click();
    await expect(page.getByTestId("signin-error")).toContainText("401");
    await page.getByTestId("admin-token").fill(readFileSync(join(data, "admin-token"), "utf8").trim());
    await shot(page, "first-run");
    await page.getByTestId("create-admin").click();
    await expect(page.getByTestId("who")).toHaveText("root-admin · admin");
    await page.reload();
    await expect(page.getByTestId("who")).toHaveText("root-admin · admin"); // signed in by the cookie
    await page.context().clearCookies();
    await page.reload();
    await expect(page.getByTestId("signin")).toBeVisible(); // a user exists now: the ordinary form
  } finally {
    agent.kill("SIGTERM");
  }
});
