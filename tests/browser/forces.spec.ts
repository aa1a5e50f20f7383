// forces.spec.ts -- forcing from the browser (docs/forcing.md, docs/webui.md, issue 30 item 5): an
// operator forces one of the cell's inputs from #/forces and the PLC reacts; the banner says "1 force
// active" on every page visited, naming who forced what; the Variables page flags the variable and
// refuses a write to it; unforce and restore brings back the value before; a viewer sees the list and
// the banner but no force, unforce or write controls, and the API answers 403 to a viewer's force.
import { readyToPower } from "./cell";
import { api, expect, server, shot, signIn, test } from "./fixtures";

const ENABLE = "PLC_ROBOT.PLC_IN.Enable"; // 1: MC_Power on (the cell's PLC powers the drives)
const POWERED = "PLC_ROBOT.PLC_OUT.Powered";
const PAGES = ["overview", "modules", "variables", "programs", "alarms", "forces"];

async function value(path: string): Promise<unknown> {
  return (await (await api(`/variables/${path}`)).json()).value;
}

async function unforceAll(): Promise<void> {
  for (const f of (await (await api("/forces")).json()).forces as { path: string }[])
    await api(`/forces/${f.path}?restore=true`, { method: "DELETE" });
}

test("an operator forces a cell input from the force list, the banner follows on every page; unforce and restore; a viewer only looks", async ({
  page,
}) => {
  const s = server();
  await unforceAll(); // the suite's cell starts with none (a test before may have failed midway)
  await readyToPower(); // no drive fault left by a test before (alarms.spec stops irpd for seconds)
  const before = await value(ENABLE);
  expect(before).toBe(0);
  try {
    await signIn(page, "operator", "#/forces");
    const banner = page.getByTestId("force-banner");
    await expect(page.getByTestId("forces-empty")).toBeVisible();
    await expect(banner).toBeHidden();

    // a value that does not fit the type is refused in the page, naming the type
    await page.getByTestId("force-path").fill(ENABLE);
    await page.getByTestId("force-value").fill("on");
    await page.getByTestId("force-submit").click();
    await expect(page.getByTestId("force-result")).toHaveText('short takes an integer, not "on"');

    // forced: the row, the banner, and the PLC powers the drives
    await page.getByTestId("force-value").fill("1");
    await page.getByTestId("force-submit").click();
    const row = page.getByTestId(`force-row-${ENABLE}`);
    await expect(row).toBeVisible();
    await expect(page.getByTestId(`force-value-${ENABLE}`)).toHaveText("1");
    await expect(page.getByTestId(`force-before-${ENABLE}`)).toHaveText("0");
    await expect(page.getByTestId(`force-by-${ENABLE}`)).toHaveText(s.users.operator.name);
    await expect(page.getByTestId(`force-type-${ENABLE}`)).toHaveText("short");
    await expect(banner).toHaveText("1 force active");
    await expect(banner).toHaveAttribute("title", new RegExp(`${ENABLE} = 1 \\(forced by ${s.users.operator.name}, `));
    await expect.poll(() => value(POWERED), { timeout: 60_000 }).toBe(1);
    await shot(page, "forces-list");

    // every page shows the banner, which leads back to the list
    for (const id of PAGES) {
      await page.goto(`${s.url}/#/${id}`);
      await expect(page.locator("main")).toHaveAttribute("data-page", id);
      await expect(banner).toHaveText("1 force active");
    }
    await page.goto(`${s.url}/#/overview`);
    await banner.click();
    await expect(page.locator("main")).toHaveAttribute("data-page", "forces");

    // the Variables page flags it; a write is refused by irpd, naming who forced it
    await page.goto(`${s.url}/#/variables`);
    await page.getByTestId("var-search").fill(ENABLE);
    await expect(page.getByTestId(`forced-${ENABLE}`)).toBeVisible();
    await expect(page.getByTestId(`value-${ENABLE}`)).toHaveText("1");
    await page.getByTestId(`write-${ENABLE}`).fill("0");
    await page.getByTestId(`set-${ENABLE}`).click();
    await expect(page.getByTestId(`result-${ENABLE}`)).toContainText(
      `409: '${ENABLE}' is forced by ${s.users.operator.name}`,
    );
    await expect(page.getByTestId(`result-${ENABLE}`)).toContainText("unforce it first");
    await expect(page.getByTestId(`unforce-${ENABLE}`)).toBeVisible();
    await shot(page, "forces-variables");

    // unforce and restore: the value before comes back, the banner goes
    await page.goto(`${s.url}/#/forces`);
    await page.getByTestId(`unforce-restore-${ENABLE}`).click();
    await expect(row).toHaveCount(0);
    await expect(page.getByTestId("forces-empty")).toBeVisible();
    await expect(banner).toBeHidden();
    expect(await value(ENABLE)).toBe(before);
    expect((await (await api(`/variables/${ENABLE}`)).json()).forced).toBe(false);

    // forced again from the Variables page, for the viewer to see
    await page.goto(`${s.url}/#/variables`);
    await page.getByTestId("var-search").fill(ENABLE);
    await page.getByTestId(`write-${ENABLE}`).fill("1");
    await page.getByTestId(`force-${ENABLE}`).click();
    await expect(page.getByTestId(`forced-${ENABLE}`)).toBeVisible();
    await expect(banner).toHaveText("1 force active");

    // a viewer: the list and the banner, no controls; the API refuses the viewer's force
    await page.getByTestId("sign-out").click();
    await expect(page.getByTestId("signin")).toBeVisible();
    await signIn(page, "viewer", "#/forces");
    await expect(page.getByTestId(`force-row-${ENABLE}`)).toBeVisible();
    await expect(banner).toHaveText("1 force active");
    await expect(page.getByTestId("force-form")).toHaveCount(0);
    await expect(page.getByTestId(`unforce-keep-${ENABLE}`)).toHaveCount(0);
    await expect(page.getByTestId(`unforce-restore-${ENABLE}`)).toHaveCount(0);
    await page.goto(`${s.url}/#/variables`);
    await page.getByTestId("var-search").fill(ENABLE);
    await expect(page.getByTestId(`forced-${ENABLE}`)).toBeVisible();
    await expect(page.getByTestId(`write-${ENABLE}`)).toHaveCount(0);
    await expect(page.getByTestId(`force-${ENABLE}`)).toHaveCount(0);
    await expect(page.getByTestId(`unforce-${ENABLE}`)).toHaveCount(0);
    const refused = await api(
      `/forces/${ENABLE}`,
      { method: "PUT", headers: { "Content-Type": "application/json" }, body: JSON.stringify({ value: 0 }) },
      "viewer",
    );
    expect(refused.status).toBe(403);
    expect((await (await api("/forces")).json()).forces[0].value).toBe(1);
  } finally {
    await unforceAll();
  }
});
