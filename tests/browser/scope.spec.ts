// scope.spec.ts -- the Scope page against an irpd of its own running the signals set (the square
// wave SIG.wave[4] rises once a second at 1 ms rows; tests/python/recorder/test_captures_live.py),
// stored and activated through the agent so that configurations can be kept with it: an operator
// arms a rising-edge capture with pre and post lengths and sees its shot plotted (the series drawn,
// the trigger's seq and the pre/post counts asked for), overlays a second shot (two series), saves
// the configuration with the set, reloads and restores it; a refusal shows next to the form; a
// viewer sees the captures and the downloads but no button that changes anything.
import { readFileSync } from "node:fs";
import { join } from "node:path";
import type { Page } from "@playwright/test";
import { expect, fillSignIn, shot, test } from "./fixtures";
import { ROOT, type Role, type Server, startServer, stopServer } from "./server";

const SIGNALS = join(ROOT, "build/sets/signals");
const SQUARE = "SIG.wave[4]";
const SAVED = "square-rising";

let s: Server;

async function call(path: string, init: RequestInit = {}, role: Role = "admin"): Promise<Response> {
  const headers = new Headers(init.headers);
  headers.set("Authorization", `Bearer ${s.tokens[role]}`);
  return fetch(`${s.url}/api/v1${path}`, { ...init, headers });
}

async function json<T>(path: string): Promise<T> {
  const r = await call(path);
  expect(r.status, await r.clone().text()).toBe(200);
  return (await r.json()) as T;
}

test.describe.configure({ mode: "serial" });

test.beforeAll(async () => {
  s = await startServer(join(SIGNALS, "module.xml"));
  // the set in the agent's store, active: configurations are kept beside a stored set
  const form = new FormData();
  for (const f of ["module.xml", "generator.so", "layout.json"])
    form.append("files", new Blob([readFileSync(join(SIGNALS, f))]), f);
  const up = await call("/sets", { method: "POST", body: form });
  expect(up.status, await up.clone().text()).toBe(201);
  const id = ((await up.json()) as { id: string }).id;
  const on = await call(
    `/sets/${id}/activate`,
    { method: "POST", body: JSON.stringify({ mode: "online" }), headers: { "Content-Type": "application/json" } },
    "operator",
  );
  expect(on.status, await on.clone().text()).toBe(200);
});

test.afterAll(async () => {
  if (s) await stopServer(s);
});

async function openScope(page: Page, role: Role): Promise<void> {
  await page.goto(`${s.url}/#/scope`);
  await fillSignIn(page, s.users[role]);
  await expect(page.getByTestId("who")).toContainText(role);
  await expect(page.getByTestId("scope-page")).toBeVisible();
}

async function pick(page: Page, path: string): Promise<void> {
  await page.getByTestId("var-search").fill(path);
  await page.getByTestId(`plotvar-${path}`).click();
}

interface Capture {
  id: string;
  shots: { shot: number; trigger_seq: number; pre_rows: number; post_rows: number }[];
}

test("an operator arms a rising edge, sees the shot plotted, overlays a second, saves and restores it", async ({
  page,
}) => {
  await openScope(page, "operator");
  await expect(page.getByTestId("capture-limits")).toContainText("rows before the trigger");
  await pick(page, SQUARE);
  await expect(page.getByTestId(`capvar-${SQUARE}`)).toBeVisible();
  await expect(page.getByTestId("cond-0-variable")).toHaveValue(SQUARE); // the first variable chosen
  await page.getByTestId("cond-0-kind").selectOption("edge");
  await page.getByTestId("cond-0-direction").selectOption("rising");
  await page.getByTestId("cond-0-threshold").fill("0");

  // a pre-trigger longer than the rings hold: refused next to the form, with the limit the agent gave
  await page.getByTestId("pre").fill("1000000");
  await page.getByTestId("arm").click();
  await expect(page.getByTestId("form-error")).toContainText("longer than the trace rings hold");
  const limits = await json<{ max_pre_rows: number }>("/captures/limits");
  await expect(page.getByTestId("form-error")).toContainText(`at most ${limits.max_pre_rows} rows`);

  await page.getByTestId("pre").fill("200");
  await page.getByTestId("post").fill("100");
  const canvas = page.getByTestId("plot-panel-1").locator("canvas").first();
  const empty = await canvas.screenshot();
  await page.getByTestId("arm").click();
  await expect(page.getByTestId("form-error")).toBeHidden();

  // the shot, plotted as it comes (the page follows the capture armed there)
  const info = page.getByTestId("shot-info-0");
  await expect(info).toHaveAttribute("data-trigger-seq", /^\d+$/, { timeout: 30_000 });
  const captures = (await json<{ captures: Capture[] }>("/captures")).captures;
  expect(captures).toHaveLength(1);
  const c = captures[0];
  expect(c.shots).toHaveLength(1);
  await expect(info).toHaveAttribute("data-trigger-seq", String(c.shots[0].trigger_seq));
  await expect(info).toHaveAttribute("data-pre", "200");
  await expect(info).toHaveAttribute("data-post", "100");
  await expect(info).toContainText(`trigger seq ${c.shots[0].trigger_seq}`);
  await expect(info).toContainText("200 rows before, 100 after");
  const panel = page.getByTestId("plot-panel-1");
  await expect(panel.locator(".chip")).toHaveCount(1);
  await expect(panel).toHaveAttribute("data-points", /^[1-9]\d*$/);
  await expect(panel.getByTestId("panel-info")).toContainText("301 rows");
  expect(Buffer.compare(empty, await canvas.screenshot())).not.toBe(0);
  await expect(page.getByTestId(`state-${c.id}`)).toHaveText("done");
  await shot(page, "scope-shot");

  // a second shot: armed again, then the first overlaid on the second's time axis
  await page.getByTestId(`rearm-${c.id}`).click();
  await expect(page.getByTestId(`capture-${c.id}`)).toHaveAttribute("data-shots", "2", { timeout: 30_000 });
  await page.getByTestId(`shot-pick-${c.id}`).selectOption("2");
  await page.getByTestId(`plot-${c.id}`).click();
  await page.getByTestId(`shot-pick-${c.id}`).selectOption("1");
  await page.getByTestId(`overlay-${c.id}`).click();
  await expect(page.getByTestId("shot-info-1")).toBeVisible();
  await expect(panel.locator(".chip")).toHaveCount(2);
  await expect(panel.locator(".chip").nth(0)).toContainText(`#2: ${SQUARE}`);
  await expect(panel.locator(".chip").nth(1)).toContainText(`#1: ${SQUARE}`);
  await expect(page.getByTestId("shot-info-1")).toHaveAttribute("data-trigger-seq", String(c.shots[0].trigger_seq));
  await shot(page, "scope-overlay");

  // the shots are in the recordings' list, with their downloads
  const shotEntry = `${c.id}.shot-1`;
  await expect(page.getByTestId(`rec-${shotEntry}`)).toHaveAttribute("data-kind", "capture", { timeout: 10_000 });
  await expect(page.getByTestId(`download-${shotEntry}`)).toHaveAttribute(
    "href",
    `/api/v1/recordings/${shotEntry}/download`,
  );

  // saved with the active set, the page reloaded, restored into the form
  await page.getByTestId("save-name").fill(SAVED);
  await page.getByTestId("save-scope").click();
  await expect(page.getByTestId(`saved-${SAVED}`)).toContainText(`${SQUARE} rising 0`);
  const active = await json<{ id: string }>("/sets/active");
  const stored = await json<{ config: { capture: { pre: { rows: number } } } }>(`/sets/${active.id}/scopes/${SAVED}`);
  expect(stored.config.capture.pre.rows).toBe(200);
  await page.reload();
  await expect(page.getByTestId("scope-page")).toBeVisible();
  await expect(page.getByTestId("pre")).toHaveValue("200"); // the form's default
  await page.getByTestId("pre").fill("5");
  await page.getByTestId(`restore-${SAVED}`).click();
  await expect(page.getByTestId(`capvar-${SQUARE}`)).toBeVisible();
  await expect(page.getByTestId("cond-0-variable")).toHaveValue(SQUARE);
  await expect(page.getByTestId("cond-0-direction")).toHaveValue("rising");
  await expect(page.getByTestId("pre")).toHaveValue("200");
  await expect(page.getByTestId("post")).toHaveValue("100");
  await expect(page.getByTestId("save-name")).toHaveValue(SAVED);
  await shot(page, "scope-restored");
});

test("a viewer sees the captures and the downloads but no button that changes anything", async ({ page }) => {
  await openScope(page, "viewer");
  const c = (await json<{ captures: Capture[] }>("/captures")).captures[0];
  await expect(page.getByTestId(`capture-${c.id}`)).toBeVisible();
  await expect(page.getByTestId(`plot-${c.id}`)).toBeVisible();
  for (const id of ["arm", "save-scope", "rec-start", `rearm-${c.id}`, `delete-${c.id}`, `arm-saved-${SAVED}`])
    await expect(page.getByTestId(id)).toHaveCount(0);
  await expect(page.getByTestId(`restore-${SAVED}`)).toBeVisible();
  await expect(page.getByTestId(`download-${c.id}.shot-1`)).toBeVisible();
  await expect(page.locator("[data-testid^=rec-delete-]")).toHaveCount(0);
});
