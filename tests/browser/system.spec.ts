// system.spec.ts -- the System page as an admin sees it: the agent's and irpd's versions, the data
// folder and the certificate line; the agent's log shown and searched; a backup downloaded and checked by
// a restore's dry run (its review shown, then cancelled); the prune's dry run; a restart asked for
// and cancelled (the suite's one irpd keeps running).  A viewer has no System page.
import { readFileSync } from "node:fs";
import { api, expect, shot, signIn, test } from "./fixtures";

test("an admin sees the system's figures, its logs, a backup's review and the prune's dry run", async ({ page }) => {
  await signIn(page, "admin", "#/system");
  await expect(page.getByTestId("system-page")).toBeVisible();
  const system = (await (await api("/system")).json()) as { agent: { version: string }; irpd: { pid: number } };
  await expect(page.getByTestId("agent-version")).toContainText(system.agent.version);
  await expect(page.getByTestId("irpd-version")).toContainText(`pid ${system.irpd.pid}`);
  await expect(page.getByTestId("data-used")).toContainText("used");
  await expect(page.getByTestId("tls-subject")).toContainText("plain HTTP");
  await expect(page.getByTestId("log-sources")).toContainText("irpd.log");

  // the agent's log (the file serve.py has it write: its start lines at least), then searched
  await page.getByTestId("log-select").selectOption("agent");
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-lines-view")).toContainText("indurop-agent");
  const shown = await page.getByTestId("log-lines-view").locator(".ops-log-line").count();
  await page.getByTestId("log-grep").fill("INDUROP-AGENT"); // any case
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-info")).toContainText(/, [1-9]\d* line\(s\)/);
  const found = await page.getByTestId("log-lines-view").locator(".ops-log-line").count();
  expect(found).toBeGreaterThan(0);
  expect(found).toBeLessThanOrEqual(shown);
  await page.getByTestId("log-grep").fill("no line holds this text 1f2e3d");
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-info")).toContainText(", 0 line(s)");
  await page.getByTestId("log-grep").fill("");

  // a backup downloaded, then reviewed by a restore's dry run; the restore itself is cancelled
  const [download] = await Promise.all([page.waitForEvent("download"), page.getByTestId("backup-download").click()]);
  expect(download.suggestedFilename()).toMatch(/^indurop-backup-.*\.tar\.gz$/);
  const file = await download.path();
  expect(readFileSync(file).subarray(0, 2)).toEqual(Buffer.from([0x1f, 0x8b])); // gzip
  await page.getByTestId("restore-file").setInputFiles(file);
  await page.getByTestId("restore-check").click();
  await expect(page.getByTestId("restore-plan")).toContainText("already here");
  await expect(page.getByTestId("restore-files")).toContainText("tokens.json");
  await expect(page.getByTestId("restore-confirm")).toBeVisible();
  await shot(page, "system-restore-review");
  await page.getByTestId("restore-confirm-no").click();
  await expect(page.getByTestId("restore-confirm")).toBeHidden();

  // the prune's dry run: a report, deleting nothing
  const before = ((await (await api("/sets")).json()) as unknown[]).length;
  await page.getByTestId("prune-keep").fill("1000");
  await page.getByTestId("prune-dry-run").click();
  await expect(page.getByTestId("prune-report")).toContainText("would delete 0 set(s)");
  expect(((await (await api("/sets")).json()) as unknown[]).length).toBe(before);

  // a restart is asked for before it is sent
  await page.getByTestId("restart-irpd").click();
  await expect(page.getByTestId("restart-confirm")).toContainText("safe values");
  await shot(page, "system");
  await page.getByTestId("restart-confirm-no").click();
  await expect(page.getByTestId("restart-confirm")).toBeHidden();
});

test("a viewer has no System page: not in the menu, its address shows the Overview, its API refuses", async ({
  page,
}) => {
  await signIn(page, "viewer", "#/system");
  await expect(page.locator("nav a[data-page=overview]")).toBeVisible();
  await expect(page.locator("nav a[data-page=system]")).toHaveCount(0);
  await expect(page.locator("main[data-page=overview]")).toBeVisible();
  expect((await api("/system", {}, "viewer")).status).toBe(403);
});
