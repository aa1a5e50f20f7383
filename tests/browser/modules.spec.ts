// modules.spec.ts -- the Modules page: the table shows the running set; editing a period in the UI
// changes it in the API (after the preview of the new slot table); a viewer gets no edit controls.
import { api, expect, shot, signIn, test } from "./fixtures";

test("the module table shows the running set", async ({ page }) => {
  await signIn(page, "operator", "#/modules");
  const running = (await (await api("/modules")).json()) as { name: string }[];
  expect(running.length).toBeGreaterThan(2);
  for (const m of running) await expect(page.getByTestId(`module-row-${m.name}`)).toBeVisible();
  await expect(page.getByTestId("edit-period-Robot")).toHaveValue(/^10\s*ms$/);
  await expect(page.getByTestId("module-row-Robot")).toContainText("running");
  await shot(page, "modules");
});

test("editing a period in the UI changes it in the API", async ({ page }) => {
  await signIn(page, "operator", "#/modules");
  const before = await (await api("/modules/main")).json();
  expect(before.period_ns).toBe(10_000_000);
  await page.getByTestId("edit-period-main").fill("20ms");
  await page.getByTestId("apply").click();
  await expect(page.getByTestId("preview")).toBeVisible();
  await expect(page.getByTestId("preview")).toContainText("main");
  await shot(page, "modules-preview");
  await page.getByTestId("confirm").click();
  await expect(page.getByTestId("swap-report")).toContainText("main");
  await expect.poll(async () => (await (await api("/modules/main")).json()).period_ns).toBe(20_000_000);
  const gen = (await (await api("/status")).json()).generation;
  expect(gen).toBeGreaterThan(1);
  await shot(page, "modules-swap-report");
  // put it back for the other tests
  const r = await api("/modules/main", {
    method: "PATCH",
    body: JSON.stringify({ period_ns: 10_000_000 }),
    headers: { "Content-Type": "application/json" },
  });
  expect(r.status).toBe(200);
});

test("a viewer sees the table without edit controls", async ({ page }) => {
  await signIn(page, "viewer", "#/modules");
  await expect(page.getByTestId("module-row-main")).toBeVisible();
  await expect(page.getByTestId("edit-period-main")).toHaveCount(0);
  await expect(page.getByTestId("apply")).toHaveCount(0);
});
