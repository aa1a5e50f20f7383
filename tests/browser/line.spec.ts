// line.spec.ts -- the Line page (docs/dds.md "The line"): this controller (browser-cell, marked, its
// link opening its own web UI in a new tab) and another controller on the same DDS domain whose
// irpd does not answer (ghost: red, fault); ghost's bridge killed, it turns lost within its lease.
// An agent that reads no view of the line says its DDS bridge is off instead of an empty table.
import { expect, server, shot, signIn, test } from "./fixtures";

test("the Line page lists the controllers with their state and a link to each one's web UI", async ({ page }) => {
  await signIn(page, "viewer", "#/line");
  const me = page.getByTestId("line-row-browser-cell");
  await expect(me).toBeVisible({ timeout: 60_000 });
  await expect(me).toHaveAttribute("data-state", /^(ok|warning)$/); // earlier tests may leave alarms active
  await expect(me.getByTestId("line-this")).toBeVisible();
  const link = me.getByTestId("line-link");
  await expect(link).toHaveAttribute("href", `${server().url}/`);
  await expect(link).toHaveAttribute("target", "_blank");
  await expect(page.getByTestId("line-notice")).toBeHidden();

  const ghost = page.getByTestId("line-row-ghost");
  await expect(ghost).toHaveAttribute("data-state", "fault", { timeout: 60_000 });
  await expect(ghost.getByTestId("line-state")).toHaveClass(/bad/);
  await expect(ghost).toContainText("irpd unreachable");
  await expect(ghost.getByTestId("line-this")).toBeHidden();
  await shot(page, "line");

  process.kill(server().pids.ghost, "SIGKILL");
  await expect(ghost).toHaveAttribute("data-state", "lost", { timeout: 60_000 });
  await expect(ghost).toContainText(/lost at \d\d:\d\d:\d\d/);
  await expect(page.getByTestId("line-info")).toContainText("1 lost");
  await shot(page, "line-lost");

  const [tab] = await Promise.all([page.waitForEvent("popup"), link.click()]);
  await tab.waitForLoadState();
  expect(tab.url()).toBe(`${server().url}/`);
  await tab.close();
});

test("without a view of the line the page says the DDS bridge is off", async ({ page }) => {
  await signIn(page, "viewer", "#/line", server().meshcat);
  const notice = page.getByTestId("line-notice");
  await expect(notice).toBeVisible();
  await expect(notice).toContainText("The DDS bridge is not running");
  await expect(page.getByTestId("line-table")).toBeHidden();
  await shot(page, "line-bridge-off");
});
