// signin.spec.ts -- sign-in: a wrong token is refused with the agent's message; each role signs in
// and the role decides what is shown as editable.
import { api, expect, server, shot, signIn, test } from "./fixtures";

test("a wrong token is refused and says why", async ({ page }) => {
  await page.goto(`${server().url}/`);
  await page.getByTestId("token").fill("not-a-token");
  await page.getByTestId("sign-in").click();
  await expect(page.getByTestId("signin-error")).toContainText("401");
  await shot(page, "signin");
});

test("the admin signs in and sees the overview", async ({ page }) => {
  await signIn(page, "admin");
  await expect(page.getByTestId("who")).toHaveText(/browser|admin/);
  const me = await (await api("/auth/me")).json();
  expect(me.role).toBe("admin");
});
