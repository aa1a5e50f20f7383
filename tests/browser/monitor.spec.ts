// monitor.spec.ts -- monitoring in the ST editor and the watch lists (docs/programming.md, issue 30 items
// 3, 4 and the editor's write/force) on the cell whose PLC is written in Structured Text: Monitor on shows
// the running values inline, equal to the API's (POST /variables/read) within a refresh, an FB instance
// expands to its fields, a condition shows its value; forcing one of the cell's inputs from the value's
// popover makes the program react (an FB input it computes from it changes, in the editor and in the
// API), unforce and restore brings it back; "Add to watch list" saves a list with the running set, which
// the Watch page shows live after a reload; a viewer sees the values but gets no actions.
// A server of its own (irpd on the ST cell, the agent), so that the suite's cell is not changed.
import type { Locator, Page } from "@playwright/test";
import { expect, shot, signIn, test } from "./fixtures";
import { type Server, startServer, stopServer } from "./server";
import { BUILT, rest, storeTheCell } from "./st_cell";

const INPUT = "PLC_ROBOT.PLC_IN.Reset"; // a panel input of the cell
const REACTS = "main.ResetRobot.Execute"; // ResetRobot(Execute := PLC_ROBOT.PLC_IN.Reset <> 0)
// lines by their words: the values drawn between the words are in a line's text too
const CALL = /^ResetRobot.*AxesGroup/; // ResetRobot(AxesGroup := Robot, Execute := PLC_ROBOT.PLC_IN.Reset <> 0);
const FIRST_SCAN = /^IF FirstScan.*THEN/;

/** The API's value of `path` (POST /variables/read), as the monitor writes it. */
async function apiText(s: Server, path: string): Promise<string> {
  const r = await rest(s, "/variables/read", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ paths: [path] }),
  });
  const v = (await r.json()).values[0]?.value;
  return typeof v === "boolean" ? (v ? "TRUE" : "FALSE") : String(v);
}

/** Scrolls the (read-only) editor until the line holding `text` is drawn. */
async function scrollTo(page: Page, text: RegExp): Promise<Locator> {
  const line = page.locator(".cm-line", { hasText: text });
  for (let i = 0; i < 60 && (await line.count()) === 0; i++)
    await page.locator(".cm-scroller").evaluate((e) => {
      e.scrollTop += 300;
    });
  await line.first().scrollIntoViewIfNeeded({ timeout: 10_000 });
  return line.first();
}

test.use({ actionTimeout: 30_000 }); // a click on a widget that is not drawn fails, not the whole budget

function value(page: Page, path: string): Locator {
  return page.locator(`[data-testid="st-mon-value"][data-path="${path}"]`).first();
}

test("Monitor shows the running values in the code; a forced input makes the program react; a watch list is saved with the set; a viewer only watches", async ({
  page,
}) => {
  test.setTimeout(600_000); // the appliance builds the uploaded set (stc, then the C++ compiler)
  const s = await startServer(`${BUILT}/module.xml`);
  try {
    const set = await storeTheCell(s);
    await signIn(page, "admin", "#/programs", s);
    await expect(page.getByTestId("st-title")).toContainText(`main.st — set ${set}`);
    await page.getByTestId("st-monitor").click();
    await expect(page.getByTestId("st-monitor-note")).toHaveText("monitoring the running version (read-only)");
    const editor = page.getByTestId("st-editor").locator(".cm-content");
    await expect(editor).toHaveAttribute("contenteditable", "false");

    // the inline values are the API's, within a refresh
    await scrollTo(page, FIRST_SCAN);
    for (const path of ["main.FirstScan", "PLC_ROBOT.PLC_IN.Enable", "PLC_ROBOT.ROBOT_MODULE_STATE.Busy"])
      await expect.poll(async () => (await value(page, path).textContent()) === (await apiText(s, path))).toBe(true);
    await expect(value(page, "main.FirstScan")).toHaveClass(/st-mon-false/);

    // the FB instance expands to its fields; the IF's condition shows its value
    const call = await scrollTo(page, CALL);
    await call.locator(`[data-path="main.ResetRobot"] [data-testid="st-mon-expand"]`).click();
    const field = page.locator(`[data-testid="st-mon-field"][data-path="${REACTS}"]`);
    await expect(field).toHaveText("Execute=FALSE");
    const condition = page.locator(".cm-line", { hasText: /^IF ResetRobot\.Error/ }).getByTestId("st-mon-cond");
    await expect(condition).toHaveText(/^(TRUE|FALSE)$/);
    await shot(page, "programs-monitor");

    // force the input from its value: the program's FB input follows it, in the editor and the API
    await value(page, INPUT).click();
    const popover = page.getByTestId("st-popover");
    await expect(popover).toBeVisible();
    await popover.getByTestId("st-pop-value").fill("1");
    await popover.getByTestId("st-pop-force").click();
    await expect(popover.getByTestId("st-pop-status")).toHaveText("Force: done");
    await expect(value(page, INPUT)).toHaveText("1 F");
    await expect(field).toHaveText("Execute=TRUE");
    expect(await apiText(s, REACTS)).toBe("TRUE");
    await shot(page, "programs-monitor-forced");
    await popover.getByTestId("st-pop-watch").click(); // into the watch list "main"
    await expect(popover.getByTestId("st-pop-status")).toHaveText("Add to watch list: done");
    await popover.getByTestId("st-pop-restore").click();
    await expect(popover.getByTestId("st-pop-status")).toHaveText("Unforce (restore): done");
    await expect(value(page, INPUT)).toHaveText("0");
    await expect(field).toHaveText("Execute=FALSE");

    // the watch list is kept with the running set; the Watch page shows it live, also after a reload
    const saved = await (await rest(s, `/sets/${set}/watches/main`)).json();
    expect(saved.config.paths).toEqual([INPUT]);
    await page.goto(`${s.url}/#/watch`);
    await expect(page.getByTestId("watch-select")).toHaveValue("main");
    await page.getByTestId("watch-add-path").fill(REACTS);
    await page.getByTestId("watch-add").click();
    await page.getByTestId("watch-save").click();
    await expect(page.getByTestId("watch-status")).toHaveText(`saved main with set ${set}`);
    await page.reload();
    for (const path of [INPUT, REACTS]) {
      const cell = page.getByTestId(`watch-row-${path}`).getByTestId("watch-value");
      await expect.poll(async () => (await cell.textContent()) === (await apiText(s, path))).toBe(true);
    }
    await shot(page, "watch");

    // a viewer: the values, no actions
    await page.getByTestId("sign-out").click();
    await expect(page.getByTestId("signin")).toBeVisible();
    await signIn(page, "viewer", "#/programs", s);
    await expect(page.getByTestId("st-title")).toContainText("main.st");
    await page.getByTestId("st-monitor").click();
    await scrollTo(page, FIRST_SCAN);
    await expect(value(page, "main.FirstScan")).toHaveText(/^(TRUE|FALSE)$/);
    await value(page, "main.FirstScan").click();
    await expect(page.getByTestId("st-popover")).toHaveCount(0);
    await page.goto(`${s.url}/#/watch`);
    await expect(page.getByTestId(`watch-row-${INPUT}`)).toBeVisible();
    await expect(page.getByTestId("watch-save")).toHaveCount(0);
    const refused = await rest(
      s,
      `/sets/${set}/watches/main`,
      {
        method: "PUT",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify({ paths: [] }),
      },
      "viewer",
    );
    expect(refused.status).toBe(403);
  } finally {
    await stopServer(s);
  }
});
