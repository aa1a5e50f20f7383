// apidocs.spec.ts -- the API docs page (/api/v1/docs) works from the agent's own files: no request
// leaves for another host, the page's Content-Security-Policy refuses nothing it needs, and the
// operations are rendered from the agent's OpenAPI document.
import { expect, server, shot, test } from "./fixtures";

test("the API docs load only from the agent and show its operations", async ({ page }) => {
  const own = new URL(server().url).origin;
  const offHost: string[] = [];
  const refused: string[] = [];
  page.on("request", (r) => {
    const url = new URL(r.url());
    if (!["data:", "blob:"].includes(url.protocol) && url.origin !== own) offHost.push(r.url());
  });
  page.on("console", (m) => {
    if (m.type() === "error") refused.push(m.text());
  });
  await page.route(
    (url) => !["data:", "blob:"].includes(url.protocol) && url.origin !== own,
    (route) => route.abort(),
  );
  await page.goto(`${server().url}/api/v1/docs`);
  await expect(page.locator(".opblock-summary-path").filter({ hasText: "/api/v1/health" }).first()).toBeVisible();
  expect(await page.locator(".opblock").count()).toBeGreaterThan(20);
  await page.locator(".opblock-summary").filter({ hasText: "/api/v1/health" }).first().click();
  await expect(page.getByRole("button", { name: "Try it out" })).toBeVisible();
  await shot(page, "api-docs");
  expect(offHost).toEqual([]);
  expect(refused).toEqual([]);
});
