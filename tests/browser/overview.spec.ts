// overview.spec.ts -- the overview shows the running set's periods and counters; when irpd stops
// answering the UI says so, and it recovers by itself when irpd answers again.
import { expect, server, shot, signIn, test } from "./fixtures";

test("the overview shows the running set", async ({ page }) => {
  await signIn(page, "viewer");
  await expect(page.getByTestId("basic-period")).toContainText("10");
  await expect(page.getByTestId("macro-period")).toContainText("10");
  await expect(page.getByTestId("irpd-health")).toContainText(/ok|running/i);
  await expect(page.getByTestId("faults")).toHaveText("none");
  await expect(page.getByTestId("event-tail")).toContainText(/start|swap|connected/i);
  await shot(page, "overview");
});

test("irpd unreachable is shown, and the UI recovers by itself", async ({ page }) => {
  await signIn(page, "viewer");
  const irpd = server().pids.irpd;
  process.kill(irpd, "SIGSTOP");
  try {
    await expect(page.getByTestId("health-banner")).toBeVisible({ timeout: 30_000 });
    await expect(page.getByTestId("health-banner")).toContainText(/irpd/i);
    await shot(page, "overview-irpd-down");
  } finally {
    process.kill(irpd, "SIGCONT");
  }
  await expect(page.getByTestId("health-banner")).toBeHidden({ timeout: 30_000 });
});
