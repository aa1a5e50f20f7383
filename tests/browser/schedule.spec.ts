// schedule.spec.ts -- the Schedule page: the slot table (Table 3) lists the modules in priority
// order, and the timeline of a macro period (Figure 2) draws each one's measured time.
import { api, expect, shot, signIn, test } from "./fixtures";

test("the slot table and the timeline show the running schedule", async ({ page }) => {
  await signIn(page, "viewer", "#/schedule");
  const schedule = await (await api("/schedule")).json();
  const table = page.getByTestId("slot-table");
  await expect(table).toBeVisible();
  const order: string[] = schedule.slots[0].modules;
  const text = await table.innerText();
  const at = order.map((m) => text.indexOf(m));
  expect(
    at.every((i) => i >= 0),
    `${order} in ${text}`,
  ).toBe(true);
  expect([...at].sort((a, b) => a - b)).toEqual(at); // priority order, as irpd runs them
  const timeline = page.getByTestId("timeline");
  await expect(timeline).toBeVisible();
  for (const m of order) await expect(timeline).toContainText(m);
  await shot(page, "schedule");
});
