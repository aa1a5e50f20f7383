// plot.spec.ts -- the Variables page: the tree lists the layout, a picked variable's live plot
// changes over time, the drop counter is shown, an operator writes a PLC input.

import { startCell } from "./cell";
import { api, expect, shot, signIn, test } from "./fixtures";

test("a live plot's canvas changes over time", async ({ page }) => {
  await startCell();
  const joint = "PLC_ROBOT.ROBOT_MODULE_STATE.dCurJoint[0]";
  await signIn(page, "operator", `#/variables?plot=${encodeURIComponent(`${joint},PLC_ROBOT.PLC_OUT.Step`)}`);
  const panel = page.getByTestId("plot-panel-1");
  await expect(panel).toBeVisible();
  await expect(page.getByTestId("drop-counter")).toBeVisible();
  const canvas = panel.locator("canvas").first();
  const a = await canvas.screenshot();
  await page.waitForTimeout(1500);
  const b = await canvas.screenshot();
  expect(Buffer.compare(a, b)).not.toBe(0);
  await shot(page, "variables");
});

test("the tree finds a variable and an operator writes it", async ({ page }) => {
  await signIn(page, "operator", "#/variables");
  await page.getByTestId("var-search").fill("Override");
  await expect(page.getByTestId("var-count")).toContainText("1 of");
  const leaf = page.getByTestId("var-PLC_ROBOT.PLC_IN.Override");
  await expect(leaf).toBeVisible();
  await page.getByTestId("write-PLC_ROBOT.PLC_IN.Override").fill("0.5");
  await page.getByTestId("set-PLC_ROBOT.PLC_IN.Override").click();
  await expect.poll(async () => (await (await api("/variables/PLC_ROBOT.PLC_IN.Override")).json()).value).toBe(0.5);
  await page.getByTestId("write-PLC_ROBOT.PLC_IN.Override").fill("1.5e400");
  await page.getByTestId("set-PLC_ROBOT.PLC_IN.Override").click();
  await expect(page.getByTestId("result-PLC_ROBOT.PLC_IN.Override")).not.toBeEmpty();
  await page.getByTestId("write-PLC_ROBOT.PLC_IN.Override").fill("1");
  await page.getByTestId("set-PLC_ROBOT.PLC_IN.Override").click();
  await expect.poll(async () => (await (await api("/variables/PLC_ROBOT.PLC_IN.Override")).json()).value).toBe(1);
});
