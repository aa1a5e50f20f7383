// programs.spec.ts -- the Programs page (docs/programming.md, issue 30 items 1 and 2) on the cell whose
// PLC is written in Structured Text (config/sets/plc-robot-st): its main.st opens in the editor; a line
// typed with a type error shows the compiler's error under that line as you type; fixed, the error
// goes; Check builds the new set and shows irpd's dry run; Activate runs it online and the editor shows
// the running version, whose history and diff name the edit; a viewer sees the program read-only.
// A server of its own (irpd on the ST cell, the agent), so that the suite's cell is not changed.
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { expect, shot, signIn, test } from "./fixtures";
import { startServer, stopServer } from "./server";
import { BUILT, MAIN, rest, storeTheCell } from "./st_cell";

const TYPED = "ErrorLatched := S;"; // a DINT assigned to a BOOL
const FIXED = "ErrorLatched := ErrorLatched OR S < 0;";

test("the cell's ST program is edited in the browser: a type error under its line, fixed, checked and applied online; history, diff; read-only for a viewer", async ({
  page,
}) => {
  test.setTimeout(600_000); // the appliance compiles the set twice (stc, then the C++ compiler)
  const s = await startServer(join(BUILT, "module.xml"));
  try {
    const base = await storeTheCell(s);
    const source = readFileSync(MAIN, "utf8").split("\n");
    const outcome = source.findIndex((l) => l.startsWith("FUNCTION MoveOutcome")) + 1; // 1-based
    const typedLine = source.findIndex((l, i) => i >= outcome && l === "MoveOutcome := FALSE;") + 2;

    await signIn(page, "admin", "#/programs", s);
    await expect(page.getByTestId("st-title")).toContainText(`main.st — set ${base}`);
    await expect(page.getByTestId("st-pou-PickAndPlace")).toBeVisible();
    const editor = page.getByTestId("st-editor").locator(".cm-content");
    await expect(editor).toContainText("PROGRAM PickAndPlace");
    await expect(page.getByTestId("st-status")).toHaveText("no errors", { timeout: 30_000 });

    // a line typed with a type error: the compiler's error under it, as you type
    await page.getByTestId("st-pou-MoveOutcome").click();
    for (let i = outcome; i < typedLine - 1; i++) await page.keyboard.press("ArrowDown");
    await page.keyboard.press("End");
    await page.keyboard.press("Enter");
    await page.keyboard.type(TYPED);
    await page.keyboard.press("Escape");
    await expect(page.getByTestId("st-status")).toHaveText("1 error", { timeout: 30_000 });
    await expect(page.getByTestId("st-errors")).toContainText(
      `main.st:${typedLine}:17: error[type]: cannot assign DINT to BOOL`,
    );
    const marked = page.locator(".cm-line", { has: page.locator(".cm-lintRange-error") });
    await expect(marked).toHaveText(TYPED);
    await shot(page, "programs-type-error");

    // fixed: no error
    await page.keyboard.press("Home");
    await page.keyboard.press("Shift+End");
    await page.keyboard.type(FIXED);
    await page.keyboard.press("Escape");
    await expect(page.getByTestId("st-status")).toHaveText("no errors", { timeout: 30_000 });
    await expect(page.locator(".cm-lintRange-error")).toHaveCount(0);
    // the type on hover: the variable under the pointer, from the check's symbols
    await page.locator(".cm-line", { hasText: FIXED }).hover({ position: { x: 20, y: 6 } });
    await expect(page.getByTestId("st-hover")).toHaveText("ErrorLatched : BOOL (VAR_IN_OUT)");

    // Check: the new set and irpd's dry run; Activate: online, then the editor shows the running version
    await page.getByTestId("st-check").click();
    const plan = page.getByTestId("st-review").getByTestId("plan");
    await expect(plan.getByTestId("plan-activate")).toBeVisible({ timeout: 300_000 });
    await expect(plan.getByTestId("plan-modules")).toContainText("main");
    await shot(page, "programs-check");
    await plan.getByTestId("plan-activate").click();
    await expect(page.getByTestId("st-report")).toBeVisible({ timeout: 60_000 });
    const running = (await (await rest(s, "/status")).json()).set_id as string;
    expect(running).not.toBe(base);
    await expect(page.getByTestId("st-title")).toContainText(`main.st — set ${running}`);
    await page.getByTestId("st-pou-MoveOutcome").click(); // the editor draws the lines in view
    await expect(editor).toContainText(FIXED);
    const derived = await (await rest(s, `/sets/${running}`)).json();
    expect(derived.derived_from).toEqual({ set_id: base, path: "main.st" });

    // the history: both versions, the running one marked; the diff names the edit
    await expect(page.getByTestId(`st-version-${running}`)).toContainText("(running)");
    await page.getByTestId(`st-version-${base}`).getByTestId("st-diff-button").click();
    await expect(page.getByTestId("st-diff")).toContainText(`+${FIXED}`);
    await shot(page, "programs-applied");

    // a viewer: the same program, read-only, no Check
    await page.getByTestId("sign-out").click();
    await expect(page.getByTestId("signin")).toBeVisible(); // signed out before the next sign-in
    await signIn(page, "viewer", "#/programs", s);
    await page.getByTestId("st-pou-MoveOutcome").click();
    await expect(editor).toContainText(FIXED);
    await expect(editor).toHaveAttribute("contenteditable", "false");
    await expect(page.getByTestId("st-check")).toHaveCount(0);
  } finally {
    await stopServer(s);
  }
});
