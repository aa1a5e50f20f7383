// robot.spec.ts -- the 3D view loads from the set's URDF and moves with the joint variables, in
// both viewers (viser on the main agent, meshcat on the second agent of the same irpd); the joint
// readouts beside it follow the robot.
import type { Page } from "@playwright/test";
import { startCell } from "./cell";
import { expect, server, shot, signIn, test } from "./fixtures";

async function expectMoving(page: Page, name: string): Promise<void> {
  const view = page.getByTestId("robot-viewer");
  await expect(view).toBeVisible();
  const frame = page.frameLocator("[data-testid=robot-viewer]");
  await expect(frame.locator("canvas").first()).toBeVisible({ timeout: 60_000 });
  await page.waitForTimeout(3000); // the scene loads its geometry
  const readouts = page.getByTestId("joint-readouts");
  await expect(readouts).toContainText("joint_1");
  // The robot moves while the cycle runs; a loaded machine may stall the simulated drives into an
  // error, so the cell is started again when it stopped.
  let moved = false;
  for (let i = 0; i < 15 && !moved; i++) {
    await startCell();
    const a = await view.screenshot();
    const ra = await readouts.innerText();
    await page.waitForTimeout(1000);
    const b = await view.screenshot();
    const rb = await readouts.innerText();
    moved = Buffer.compare(a, b) !== 0 && ra !== rb;
  }
  expect(moved, "the 3D view and the joint readouts did not change while the robot moved").toBe(true);
  await shot(page, name);
}

test("the viser view loads and moves", async ({ page }) => {
  await startCell();
  await signIn(page, "viewer", "#/robot");
  await expectMoving(page, "robot-viser");
});

test("the meshcat view loads and moves", async ({ page }) => {
  await startCell();
  await signIn(page, "viewer", "#/robot", server().meshcat);
  await expectMoving(page, "robot-meshcat");
});
