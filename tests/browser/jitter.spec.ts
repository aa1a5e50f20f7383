// jitter.spec.ts -- the jitter dashboard draws a histogram per module and for the dispatcher, and
// its jitter-over-time plot.
import { expect, shot, signIn, test } from "./fixtures";

test("the jitter page draws its histograms", async ({ page }) => {
  await signIn(page, "viewer", "#/jitter");
  for (const name of ["dispatcher", "Robot", "main"]) {
    const hist = page.getByTestId(`hist-${name}`);
    await expect(hist).toBeVisible();
    const box = await hist.boundingBox();
    expect(box!.width).toBeGreaterThan(100);
  }
  const hist = page.getByTestId("hist-Robot");
  const drawn = await hist
    .locator("canvas")
    .first()
    .evaluate((c: HTMLCanvasElement) => {
      const d = c.getContext("2d")!.getImageData(0, 0, c.width, c.height).data;
      let ink = 0;
      for (let i = 3; i < d.length; i += 4) if (d[i] > 0) ink++;
      return ink;
    });
  expect(drawn).toBeGreaterThan(100);
  await page.waitForTimeout(3000);
  await expect(page.getByTestId("jitter-time-Robot")).toBeVisible();
  await shot(page, "jitter");
});
