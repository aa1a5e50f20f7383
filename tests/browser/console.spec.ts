// console.spec.ts -- a tour of every page, as a viewer and as an admin: no error in the browser's
// console, no uncaught exception, no failed request and no answer of 400 or more, from the page or
// its frames (the Robot page's 3D view).  The browser's own requests (the icon) are seen only in
// the console: a missing icon was "Failed to load resource: ... 404" there.
import type { Page } from "@playwright/test";
import { expect, signIn, test } from "./fixtures";

/** Everything that went wrong in the browser while `page` was open, one line each. */
function problems(page: Page): string[] {
  const seen: string[] = [];
  page.on("console", (m) => {
    if (m.type() === "error") seen.push(`console error: ${m.text()} (${m.location().url})`);
  });
  page.on("pageerror", (e) => seen.push(`uncaught: ${e.message}`));
  page.on("requestfailed", (r) => seen.push(`failed: ${r.method()} ${r.url()}: ${r.failure()?.errorText}`));
  page.on("response", (r) => {
    if (r.status() >= 400) seen.push(`${r.status()}: ${r.request().method()} ${r.url()}`);
  });
  return seen;
}

for (const role of ["viewer", "admin"] as const) {
  test(`every page as ${role}: no console error, no failed request`, async ({ page }) => {
    const seen = problems(page);
    await signIn(page, role);
    const pages = await page
      .locator("nav a")
      .evaluateAll((links) => links.map((a) => (a as HTMLElement).dataset.page!));
    expect(pages).toEqual(expect.arrayContaining(["overview", "modules", "schedule", "jitter", "variables", "robot"]));
    for (const id of pages) {
      await page.locator(`nav a[data-page=${id}]`).click();
      // Leaving the 3D view's page can hold a loaded machine's renderer for seconds (its iframe's
      // WebGL in software): the page must come, not come fast.
      await expect(page.locator(`main[data-page=${id}]`)).toBeVisible({ timeout: 20_000 });
      await page.waitForTimeout(1500); // a poll, the stream's first frames, the 3D view's page
    }
    await page.reload(); // a fresh load of the shell, signed in: the favicon, the bundles again
    await expect(page.getByTestId("who")).toContainText(role);
    await page.waitForTimeout(1000);
    expect(seen).toEqual([]);
  });
}
