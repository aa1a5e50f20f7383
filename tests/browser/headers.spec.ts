// headers.spec.ts -- the web UI under its Content-Security-Policy: every page (with a plot's chips,
// and the 3D view in its iframe, viser's and meshcat's) runs without the browser refusing anything the policy forbids,
// and the page that frames nothing else cannot itself be framed by another page.
import { startCell } from "./cell";
import { expect, server, signIn, test } from "./fixtures";

const PAGES = [
  "#/overview",
  "#/modules",
  "#/schedule",
  `#/variables?plot=${encodeURIComponent("PLC_ROBOT.PLC_OUT.Step,PLC_ROBOT.PLC_OUT.Cycles")}`,
  "#/scope",
  "#/jitter",
  "#/alarms",
  "#/line",
  "#/opcua",
  "#/users",
  "#/system",
  "#/robot",
];

test("no page of the web UI is refused anything by its Content-Security-Policy", async ({ page }) => {
  await startCell();
  const refused: string[] = [];
  page.on("console", (m) => {
    if (/Content Security Policy|Refused to/i.test(m.text())) refused.push(`${page.url()}: ${m.text()}`);
  });
  // a refused `new Function` or eval is thrown, not logged: an uncaught error of the page or a frame
  page.on("pageerror", (e) => {
    if (/Content Security Policy/i.test(e.message)) refused.push(`${page.url()}: uncaught: ${e.message}`);
  });
  await signIn(page, "admin");
  for (const hash of PAGES) {
    await page.goto(`${server().url}/${hash}`);
    await page.waitForLoadState("networkidle").catch(() => {});
    await page.waitForTimeout(500);
  }
  await expect(page.frameLocator("[data-testid=robot-viewer]").locator("canvas").first()).toBeVisible({
    timeout: 60_000,
  });
  await page.goto(`${server().url}/${PAGES[3]}`);
  await expect(page.getByTestId("plot-panel-1").locator(".chip")).toHaveCount(2);
  expect(refused).toEqual([]);
});

test("the meshcat 3D view runs in its frame without a refusal", async ({ page }) => {
  await startCell();
  const refused: string[] = [];
  page.on("console", (m) => {
    if (/Content Security Policy|Refused to/i.test(m.text())) refused.push(m.text());
  });
  page.on("pageerror", (e) => {
    if (/Content Security Policy/i.test(e.message)) refused.push(`uncaught: ${e.message}`);
  });
  await signIn(page, "viewer", "#/robot", server().meshcat);
  await expect(page.frameLocator("[data-testid=robot-viewer]").locator("canvas").first()).toBeVisible({
    timeout: 60_000,
  });
  await page.waitForTimeout(2000);
  expect(refused).toEqual([]);
});

test("a page of another origin cannot frame the web UI", async ({ page }) => {
  const ui = `${server().url}/`;
  await page.setContent(`<iframe id="ui" src="${ui}"></iframe>`);
  const r = await page.request.get(ui);
  expect(r.headers()["x-frame-options"]).toBe("DENY");
  expect(r.headers()["content-security-policy"]).toContain("frame-ancestors 'none'");
  await page.waitForTimeout(1000);
  const framed = page.frames().find((f) => f.url().startsWith(ui));
  expect(framed === undefined || (await framed.locator("#app").count()) === 0).toBe(true);
});
