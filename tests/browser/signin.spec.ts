// signin.spec.ts -- sign-in with a user name and a password: a wrong password is refused with the
// agent's message; each role signs in and the role decides what is shown; signing out ends the
// session on the agent (its cookie is refused afterwards); a reload keeps the session.
import { api, expect, fillSignIn, server, shot, signIn, test } from "./fixtures";

test("a wrong password is refused and says why", async ({ page }) => {
  await page.goto(`${server().url}/`);
  await fillSignIn(page, { name: server().users.viewer.name, password: "not-the-password" });
  await expect(page.getByTestId("signin-error")).toContainText("401");
  await expect(page.getByTestId("signin-error")).toContainText("wrong user name or password");
  await expect(page.getByTestId("who")).toHaveCount(0);
  await shot(page, "signin");
});

test("the admin signs in with name and password and sees the overview; a reload keeps the session", async ({
  page,
}) => {
  await signIn(page, "admin");
  await expect(page.getByTestId("who")).toHaveText(`${server().users.admin.name} · admin`);
  await expect(page.locator("nav a[data-page=users]")).toBeVisible();
  await page.reload();
  await expect(page.getByTestId("who")).toContainText("admin");
  const me = await (await api("/auth/me")).json();
  expect(me.role).toBe("admin");
});

test("a viewer sees no Users page", async ({ page }) => {
  await signIn(page, "viewer");
  await expect(page.locator("nav a[data-page=overview]")).toBeVisible();
  await expect(page.locator("nav a[data-page=users]")).toHaveCount(0);
});

test("signing out ends the session on the agent: its cookie is refused afterwards", async ({ page }) => {
  await signIn(page, "operator");
  const cookie = (await page.context().cookies()).find((c) => c.name === "indurop_session");
  expect(cookie?.httpOnly).toBe(true);
  expect(cookie?.sameSite).toBe("Strict");
  const withCookie = () =>
    fetch(`${server().url}/api/v1/status`, { headers: { Cookie: `indurop_session=${cookie?.value}` } });
  expect((await withCookie()).status).toBe(200);
  await page.getByTestId("sign-out").click();
  await expect(page.getByTestId("signin")).toBeVisible();
  expect((await withCookie()).status).toBe(401);
});
