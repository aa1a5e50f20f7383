// upload.spec.ts -- uploading a set with a broken module.xml shows the agent's error with its file
// and line; nothing is stored.  A set whose layout adds a shared variable shows the variable diff
// before its one activation; one that only a restart can run waits for the confirmation.
import { mkdirSync, mkdtempSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { api, expect, shot, signIn, test } from "./fixtures";
import { ROOT, startServer, stopServer } from "./server";

const BROKEN = `<?xml version="1.0"?>
<root>
<module>
  <filename>./x.so</filename>
  <moduletype>thread</modultype>
</module>
</root>
`;

test("a broken module.xml is refused with its line", async ({ page }) => {
  const setsBefore = (await (await api("/sets")).json()).length;
  await signIn(page, "admin", "#/modules");
  await page
    .locator("input[type=file]")
    .first()
    .setInputFiles({ name: "module.xml", mimeType: "text/xml", buffer: Buffer.from(BROKEN) });
  const error = page.getByTestId("upload-error");
  await expect(error).toContainText("module.xml");
  await expect(error).toContainText(/line 5/);
  await shot(page, "upload-error");
  expect((await (await api("/sets")).json()).length).toBe(setsBefore);
});

// A cell of its own on the online-change fixtures (tests/cpp/online): irpd runs the counter on
// layout v1; the uploads bring v2 (one variable added, laid out against v1) and a layout laid out
// afresh (only a restart can run it).
const ONLINE = join(ROOT, "build/tests/cpp/online");

function counterSet(dir: string, layout: string, modules: Record<string, string>): string {
  mkdirSync(dir, { recursive: true });
  const body = Object.entries(modules)
    .map(
      ([name, file], i) =>
        `  <module><name>${name}</name><filename>${file}</filename><moduletype>thread</moduletype>` +
        `<operationtype>periodic</operationtype><period>1000000</period><priority>${i + 1}</priority></module>`,
    )
    .join("\n");
  writeFileSync(join(dir, "module.xml"), `<root>\n  <layout>${layout}</layout>\n${body}\n</root>\n`);
  return join(dir, "module.xml");
}

/** The files of an upload: module.xml naming ./<file>.so with layout.json beside it. */
function uploadOf(layout: string, modules: Record<string, string>) {
  const xml = Object.entries(modules)
    .map(
      ([name, file], i) =>
        `  <module><name>${name}</name><filename>./${file}</filename><moduletype>thread</moduletype>` +
        `<operationtype>periodic</operationtype><period>1000000</period><priority>${i + 1}</priority></module>`,
    )
    .join("\n");
  return [
    { name: "module.xml", mimeType: "text/xml", buffer: Buffer.from(`<root>\n${xml}\n</root>\n`) },
    { name: "layout.json", mimeType: "application/json", buffer: readFileSync(join(ONLINE, layout, "layout.json")) },
    ...Object.values(modules).map((file) => ({
      name: file,
      mimeType: "application/octet-stream",
      buffer: readFileSync(join(ONLINE, "modules", file)),
    })),
  ];
}

test("an upload that adds a shared variable shows the variable diff and activates online; one laid out afresh runs after a confirmed restart", async ({
  page,
}) => {
  const work = mkdtempSync(join(tmpdir(), "indurop-online-"));
  const s = await startServer(
    counterSet(work, join(ONLINE, "oc_v1/layout.json"), { counter: join(ONLINE, "modules/oc_counter_v1.so") }),
  );
  try {
    await signIn(page, "admin", "#/modules", s);

    // v2: the counter rebuilt against it (kept) and the adder writing the new variable
    await page
      .getByTestId("upload-files")
      .setInputFiles(uploadOf("oc_v2", { counter: "oc_counter_v2.so", adder: "oc_adder_v2.so" }));
    const plan = page.getByTestId("upload-result").getByTestId("plan");
    await expect(plan.getByTestId("plan-variables-summary")).toHaveText("shared variables: 1 added");
    await expect(plan.locator("[data-variable='oc.added']")).toContainText("+ added");
    await expect(plan.getByTestId("plan-after")).toBeVisible();
    await expect(plan.getByTestId("plan-restart")).toHaveCount(0);
    await expect(plan.getByTestId("plan-modules-kept")).toHaveText("counter");
    await expect(plan.getByTestId("plan-modules-new")).toHaveText("adder");
    await expect(plan.getByTestId("plan-modules-replaced")).toHaveText("—");
    await shot(page, "upload-variable-diff");
    await plan.getByTestId("plan-activate").click();
    const report = page.getByTestId("swap-report");
    await expect(report.getByTestId("report-variables-summary")).toHaveText("shared variables: 1 added");
    await expect(report.getByTestId("report-kept")).toHaveText("counter");
    await expect(report.getByTestId("report-started")).toHaveText("adder");
    await expect(report.getByTestId("report-replaced")).toHaveText("—");

    // a layout laid out afresh: only a restart can run it, and the button waits for the confirmation
    await page
      .getByTestId("upload-files")
      .setInputFiles(uploadOf("oc_reordered", { counter: "oc_counter_reordered.so" }));
    const restart = page.getByTestId("upload-result").getByTestId("plan");
    await expect(restart.getByTestId("plan-restart")).toContainText("start afresh");
    await expect(restart.getByTestId("plan-restart-reason")).toContainText("online");
    await expect(restart.getByTestId("plan-downtime")).not.toBeEmpty();
    const go = restart.getByTestId("plan-activate");
    await expect(go).toHaveText("Restart irpd onto this set");
    await expect(go).toBeDisabled();
    await restart.getByTestId("plan-restart-confirm").check();
    await expect(go).toBeEnabled();
    await shot(page, "upload-restart-needed");

    // the same review from the set history (checked again there)
    const id = (await page.getByTestId("upload-set-id").textContent()) ?? "";
    await page.getByTestId(`activate-${id}`).click();
    const fromHistory = page.getByTestId("set-review").getByTestId("plan");
    await expect(fromHistory.getByTestId("plan-restart")).toContainText("start afresh");
    await expect(fromHistory.getByTestId("plan-activate")).toBeDisabled();

    // confirmed: irpd restarts onto it (the same process), and the report gives the measured downtime
    const before = await (
      await page.request.get(`${s.url}/api/v1/status`, { headers: { Authorization: `Bearer ${s.tokens.admin}` } })
    ).json();
    await fromHistory.getByTestId("plan-restart-confirm").check();
    await fromHistory.getByTestId("plan-activate").click();
    const restarted = page.getByTestId("swap-report").last();
    await expect(restarted.getByTestId("report-downtime")).toHaveText(/^[0-9.]+ (ms|s)$/, { timeout: 30_000 });
    const after = await (
      await page.request.get(`${s.url}/api/v1/status`, { headers: { Authorization: `Bearer ${s.tokens.admin}` } })
    ).json();
    expect(after.set_id).toBe(id);
    expect(after.pid).toBe(before.pid);
    expect(after.last_restart.downtime_ns).toBeGreaterThan(0);
  } finally {
    await stopServer(s);
  }
});
