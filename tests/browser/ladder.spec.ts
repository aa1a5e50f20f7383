// ladder.spec.ts -- the live view of LD, FBD and SFC POUs (docs/programming.md "The live view", issue 31
// item 5): a real PLCopen XML project drawn in another tool (a tutorial's LD program from
// ../shared/plcopen, uploaded in place at test time through the agent) opens in the Programs page as a
// ladder drawn from the file's positions (rails, contacts normal and negated, coils, wires); Monitor on
// colours it from the agent's answer at 5 Hz (POST /programs/diagram/monitor); an input forced through
// the API (PUT /forces/...) makes its rung conduct: the contact, the wires and the coil get `pl-on`,
// the coil's variable turns TRUE in the API; unforce and restore brings the rung back to off.
// A server of its own (irpd, the agent), so that the suite's cell is not changed.
import { existsSync, readFileSync } from "node:fs";
import { join, relative } from "node:path";
import type { Page } from "@playwright/test";
import { expect, shot, signIn, test } from "./fixtures";
import { ROOT, type Server, startServer, stopServer } from "./server";
import { NOT_SHARED, SHARED_PLCOPEN } from "./shared_projects";
import { BUILT, files, rest, storeAndActivate } from "./st_cell";

const SHARED = SHARED_PLCOPEN;
const PROJECT = SHARED && join(SHARED, "tutorial_xor_xnor/plc.xml"); // MIT, SOURCES.md
const POU = "XOR_and_XNOR";
const INPUT = "instance0.INPUT_0"; // contact localId 3 (normally open) on rung 1; INPUT_1 stays FALSE
const OUTPUT = "instance0.OUTPUT_0"; // coil localId 7: INPUT_0 AND NOT INPUT_1 OR NOT INPUT_0 AND INPUT_1

async function read(s: Server, path: string): Promise<unknown> {
  const r = await rest(s, "/variables/read", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ paths: [path] }),
  });
  return (await r.json()).values[0]?.value;
}

async function upload(s: Server, file: string): Promise<string> {
  const form = new FormData();
  form.append("files", new Blob([readFileSync(file)]), "plc.xml");
  return storeAndActivate(s, form);
}

// the cell's PLC program drawn in ladder (config/sets/plc-robot-ld, written by its generate.py)
const CELL_LD = join(ROOT, "config/sets/plc-robot-ld/plc.xml");

/** The cell with its PLC in ladder, as an upload the appliance builds: the built ST cell's modules and
 * cell.glb with plc.xml in place of main.st (stc compiles it into main.so, laid out against the
 * running layout, as config/sets/plc-robot-ld's CMake does). */
async function uploadTheLadderCell(s: Server): Promise<string> {
  const form = new FormData();
  for (const p of files(BUILT)) {
    const name = relative(BUILT, p);
    if (name !== "main.st" && name !== "layout.json") form.append("files", new Blob([readFileSync(p)]), name);
  }
  form.append("files", new Blob([readFileSync(CELL_LD)]), "plc.xml");
  return storeAndActivate(s, form);
}

function element(page: Page, id: number) {
  return page.locator(`[data-testid="pl-element"][data-id="${id}"]`);
}

test("the cell's LD program live: a panel input forced makes its rung conduct", async ({ page }) => {
  test.setTimeout(600_000); // the appliance builds the uploaded set (stc, then the C++ compiler)
  const s = await startServer(`${BUILT}/module.xml`);
  try {
    const set = await uploadTheLadderCell(s);
    await signIn(page, "admin", "#/programs", s);
    await page.getByTestId("st-pou-PickAndPlace").click();
    await expect(page.getByTestId("st-title")).toContainText(`plc.xml: PROGRAM PickAndPlace (LD) — set ${set}`);
    // rung 4: Reset clears the robot's error (Inputs.ResetReq := PLC_ROBOT.PLC_IN.Reset <> 0)
    const contact = page.locator('[data-testid="pl-element"][data-kind="contact"]', { hasText: "Inputs.ResetReq" });
    await expect(contact).toHaveCount(1);
    const id = Number(await contact.getAttribute("data-id"));
    const wire = page.locator(`[data-testid="pl-wire"][data-from="${id}"]`).first();
    await page.getByTestId("st-monitor").click();
    await expect(contact).toHaveClass(/pl-off/);
    await expect(wire).toHaveClass(/pl-off/);
    const forced = await rest(s, "/forces/PLC_ROBOT.PLC_IN.Reset", {
      method: "PUT",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ value: 1 }),
    });
    expect(forced.status, await forced.clone().text()).toBe(200);
    await expect(contact).toHaveClass(/pl-on/);
    await expect(wire).toHaveClass(/pl-on/);
    await contact.scrollIntoViewIfNeeded();
    await shot(page, "programs-ladder-cell");
    const restored = await rest(s, "/forces/PLC_ROBOT.PLC_IN.Reset?restore=true", { method: "DELETE" });
    expect(restored.status, await restored.clone().text()).toBe(200);
    await expect(contact).toHaveClass(/pl-off/);
  } finally {
    await stopServer(s);
  }
});

test("an LD program opens as a ladder drawn from its file; Monitor shows a rung conduct when its input is forced", async ({
  page,
}) => {
  test.skip(!PROJECT || !existsSync(PROJECT), NOT_SHARED);
  test.setTimeout(600_000); // the appliance builds the uploaded set (stc, then the C++ compiler)
  const s = await startServer();
  try {
    const set = await upload(s, PROJECT as string);
    await signIn(page, "admin", "#/programs", s);
    await expect(page.getByTestId("st-file-plc.xml")).toContainText(`PROGRAM ${POU} (LD)`);
    await page.getByTestId(`st-pou-${POU}`).click();
    await expect(page.getByTestId("st-title")).toContainText(`plc.xml: PROGRAM ${POU} (LD) — set ${set}`);

    // the drawing: two rails, eight contacts (four negated), two coils, the wires of the file
    const svg = page.getByTestId("pl-svg");
    await expect(svg).toBeVisible();
    await expect(svg.locator('[data-kind="leftPowerRail"]')).toHaveCount(1);
    await expect(svg.locator('[data-kind="contact"]')).toHaveCount(8);
    await expect(svg.locator('[data-kind="coil"]')).toHaveCount(2);
    await expect(svg.getByTestId("pl-wire")).toHaveCount(14);
    await expect(element(page, 3)).toContainText("INPUT_0");
    await expect(element(page, 5)).toContainText("INPUT_0"); // the negated one: a slash between its bars
    await expect(element(page, 7)).toContainText("OUTPUT_0");

    // Monitor: INPUT_0 and INPUT_1 FALSE, so rung 1 does not conduct
    await page.getByTestId("st-monitor").click();
    await expect(page.getByTestId("st-monitor-note")).toHaveText("monitoring the running version (read-only)");
    await expect(element(page, 7)).toHaveClass(/pl-off/);
    await expect(element(page, 3)).toHaveClass(/pl-off/);

    // force the input: the rung conducts through contact 3 and the negated contact 6 into coil 7
    const forced = await rest(s, `/forces/${INPUT}`, {
      method: "PUT",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ value: true }),
    });
    expect(forced.status, await forced.clone().text()).toBe(200);
    await expect(element(page, 3)).toHaveClass(/pl-on/);
    await expect(element(page, 3)).toHaveClass(/pl-forced/);
    await expect(element(page, 6)).toHaveClass(/pl-on/);
    await expect(element(page, 7)).toHaveClass(/pl-on/);
    await expect(page.locator('[data-testid="pl-wire"][data-from="6"][data-to="7"]')).toHaveClass(/pl-on/);
    await expect(element(page, 5)).toHaveClass(/pl-off/); // the other branch: NOT INPUT_0
    await expect.poll(() => read(s, OUTPUT)).toBe(true);
    await shot(page, "programs-ladder");

    // unforce and restore: the rung is off again
    const restored = await rest(s, `/forces/${INPUT}?restore=true`, { method: "DELETE" });
    expect(restored.status, await restored.clone().text()).toBe(200);
    await expect(element(page, 7)).toHaveClass(/pl-off/);
    await expect.poll(() => read(s, OUTPUT)).toBe(false);
  } finally {
    await stopServer(s);
  }
});

test("an SFC function block's active step is highlighted with its time, and follows its transition", async ({
  page,
}) => {
  const project = SHARED && join(SHARED, "beremiz_first_steps/plc.xml"); // GPL-2.0-or-later, SOURCES.md
  test.skip(!project || !existsSync(project), NOT_SHARED);
  test.setTimeout(600_000);
  const s = await startServer();
  try {
    await upload(s, project as string);
    await signIn(page, "admin", "#/programs", s);
    await page.getByTestId("st-pou-CounterSFC").click();
    await expect(page.getByTestId("st-title")).toContainText("FUNCTION_BLOCK CounterSFC (SFC)");
    await expect(page.locator('[data-kind="step"]')).toHaveCount(3);
    await page.getByTestId("st-monitor").click();
    // Reset FALSE: the step Count (localId 7) is active, its time shown and growing
    await expect(element(page, 7)).toHaveClass(/pl-active/);
    await expect(element(page, 5)).not.toHaveClass(/pl-active/);
    await expect(element(page, 7)).toContainText(/T=\d/);
    await shot(page, "programs-sfc");
    // Reset TRUE: through Start to ResetCounter (localId 5)
    const w = await rest(s, "/variables/plc_task_instance.Reset", {
      method: "PUT",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ value: true }),
    });
    expect(w.status, await w.clone().text()).toBe(200);
    await expect(element(page, 5)).toHaveClass(/pl-active/);
    await expect(element(page, 7)).not.toHaveClass(/pl-active/);
  } finally {
    await stopServer(s);
  }
});
