// robot.spec.ts -- the 3D view loads from the set's URDF and moves with the joint variables, in
// both viewers (viser on the main agent, meshcat on the second agent of the same irpd); the joint
// readouts beside it follow the robot.
import type { Page } from "@playwright/test";
import { expect, server, shot, test } from "./fixtures";
import { startCell } from "./cell";

async function openRobot(page: Page, url: string, token: string): Promise<void> {
  await page.goto(`${url}/?token=${encodeURIComponent(token)}#/robot`);
  await expect(page.getByTestId("who")).toBeVisible();
}

async function expectMoving(page: Page, name: string): Promise<void> {
  const view = page.getByTestId("robot-viewer");
  await expect(view).toBeVisible();
  const frame = page.frameLocator("[data-testid=robot-viewer]");
  await expect(frame.locator("canvas").first()).toBeVisible({ timeout: 60_000 });
  await page.waitForTimeout(3000); // the scene loads its geometry
  const readouts = page.getByTestId("joint-readouts");
  await expect(readouts).toContainText("joint_1");
  const a = await view.screenshot();
  const ra = await readouts.innerText();
  await page.waitForTimeout(2000);
  const b = await view.screenshot();
  const rb = await readouts.innerText();
  expect(Buffer.compare(a, b), "the 3D view did not change while the robot moved").not.toBe(0);
  expect(ra, "the joint readouts did not change while the robot moved").not.toBe(rb);
  await shot(page, name);
}

test("the viser view loads and moves", async ({ page }) => {
  await startCell();
  const s = server();
  await openRobot(page, s.url, s.tokens.viewer);
  await expectMoving(page, "robot-viser");
});

test("the meshcat view loads and moves", async ({ page }) => {
  await startCell();
  const s = server().meshcat;
  await openRobot(page, s.url, s.tokens.viewer);
  await expectMoving(page, "robot-meshcat");
});
