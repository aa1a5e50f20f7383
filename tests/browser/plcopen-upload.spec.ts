// plcopen-upload.spec.ts -- issue 31's "Done when" in the browser: a PLCopen XML project drawn in another
// tool, with LD, FBD, SFC, ST and IL POUs (Beremiz's first_steps example, ../shared/plcopen, read in place
// at test time), uploaded from the Modules page, compiled on the appliance, activated and running (the
// five counters count); uploaded again with a change (the global constant ResetCounterValue 17 -> 23)
// and activated online, the counters keeping their values; its ladder shown live on the Programs page
// (the LD counter's Reset contact conducts when Reset is written TRUE).  A server of its own (irpd on the
// paper's Figure 1 set, the agent), so that the suite's cell is not changed.
import { existsSync, readFileSync } from "node:fs";
import { join } from "node:path";
import type { Page } from "@playwright/test";
import { expect, shot, signIn, test } from "./fixtures";
import { ROOT, type Server, startServer, stopServer } from "./server";
import { NOT_SHARED, SHARED_PLCOPEN } from "./shared_projects";

const FIG1 = join(ROOT, "build/sets/paper-fig1/module.xml");
const SHARED = SHARED_PLCOPEN;
const PROJECT = SHARED && join(SHARED, "beremiz_first_steps/plc.xml"); // GPL-2.0-or-later, SOURCES.md
const COUNTERS = ["Cnt1", "Cnt2", "Cnt3", "Cnt4", "Cnt5"].map((c) => `plc_task_instance.${c}`); // ST FBD SFC IL LD

async function rest(s: Server, path: string, init: RequestInit = {}): Promise<Response> {
  const headers = { Authorization: `Bearer ${s.tokens.admin}`, ...(init.headers ?? {}) };
  return fetch(`${s.url}/api/v1${path}`, { ...init, headers });
}

async function values(s: Server, paths: string[]): Promise<number[]> {
  const r = await rest(s, "/variables/read", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ paths }),
  });
  expect(r.status, await r.clone().text()).toBe(200);
  return (await r.json()).values.map((v: { value: number }) => v.value);
}

async function write(s: Server, path: string, value: boolean): Promise<void> {
  const r = await rest(s, `/variables/${path}`, {
    method: "PUT",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ value }),
  });
  expect(r.status, await r.clone().text()).toBe(200);
}

/** Uploads `data` as plc.xml from the Modules page and activates it; the new set's id. */
async function uploadAndActivate(page: Page, s: Server, data: Buffer, shotName: string): Promise<string> {
  await page.goto(`${s.url}/#/modules`);
  await page.reload(); // the Modules page afresh: no earlier upload's result on it
  await page
    .getByTestId("upload-files")
    .setInputFiles([{ name: "plc.xml", mimeType: "application/xml", buffer: data }]);
  const result = page.getByTestId("upload-result");
  await expect(result.getByTestId("upload-set-id")).not.toBeEmpty({ timeout: 300_000 });
  const id = (await result.getByTestId("upload-set-id").textContent()) ?? "";
  const plan = result.getByTestId("plan");
  await expect(plan.getByTestId("plan-activate")).toBeVisible();
  const confirm = plan.getByTestId("plan-restart-confirm");
  if (await confirm.count()) await confirm.check(); // Figure 1's layout is not the project's
  await shot(page, shotName);
  await plan.getByTestId("plan-activate").click();
  await expect(page.getByTestId("swap-report").last()).toBeVisible({ timeout: 60_000 });
  await expect.poll(async () => (await (await rest(s, "/status")).json()).set_id, { timeout: 30_000 }).toBe(id);
  return id;
}

test("a PLCopen XML project with LD, FBD and SFC POUs uploaded from the browser runs, is changed online, and its ladder is live", async ({
  page,
}) => {
  test.skip(!PROJECT || !existsSync(PROJECT), NOT_SHARED);
  test.setTimeout(900_000); // the appliance builds each upload (stc, then the C++ compiler)
  const original = readFileSync(PROJECT as string);
  const changed = Buffer.from(
    original.toString("utf8").replace('<simpleValue value="17"/>', '<simpleValue value="23"/>'),
    "utf8",
  );
  expect(changed.equals(original)).toBe(false);
  const s = await startServer(FIG1);
  try {
    await signIn(page, "admin", "#/modules", s);
    const firstId = await uploadAndActivate(page, s, original, "plcopen-upload-plan");

    // it runs: the five counters (ST, FBD, SFC, IL, LD) count
    const first = await values(s, COUNTERS);
    await expect.poll(async () => (await values(s, COUNTERS)).every((v, i) => v > first[i] && v > 0)).toBe(true);

    // changed online: the same project with ResetCounterValue 23, activated without a restart
    const before = await values(s, COUNTERS);
    const id = await uploadAndActivate(page, s, changed, "plcopen-upload-change");
    expect(id).not.toBe(firstId);
    const report = page.getByTestId("swap-report").last();
    await expect(report).not.toContainText("restart");
    const after = await values(s, COUNTERS);
    for (const [i, v] of after.entries()) expect(v, `${COUNTERS[i]} kept its value`).toBeGreaterThanOrEqual(before[i]);
    await write(s, "plc_task_instance.Reset", true);
    await expect.poll(async () => await values(s, COUNTERS)).toEqual([23, 23, 23, 23, 23]);

    // the ladder live: the LD counter's Reset contact conducts while Reset is TRUE, not once it is FALSE
    await page.goto(`${s.url}/#/programs`);
    await page.getByTestId("st-pou-CounterLD").click();
    await expect(page.getByTestId("st-title")).toContainText(`plc.xml: FUNCTION_BLOCK CounterLD (LD) — set ${id}`);
    const contact = page.locator('[data-testid="pl-element"][data-kind="contact"]', { hasText: "Reset" });
    await expect(contact).toHaveCount(1);
    await page.getByTestId("st-monitor").click();
    await expect(contact).toHaveClass(/pl-on/);
    await shot(page, "plcopen-upload-ladder");
    await write(s, "plc_task_instance.Reset", false);
    await expect(contact).toHaveClass(/pl-off/);
  } finally {
    await stopServer(s);
  }
});
