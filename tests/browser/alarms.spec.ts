// alarms.spec.ts -- the alarm banner in the bar of every page counts what needs attention, live:
// irpd stopped (SIGSTOP) longer than the agent's alarm_unreachable_s raises agent/irpd_unreachable,
// and the banner's count goes up on whatever page is open; an operator opens the Alarms page from
// the banner and acknowledges it there, and the acknowledgement is in the history and the audit log.
import type { Page } from "@playwright/test";
import { api, expect, server, shot, signIn, test } from "./fixtures";

const KEY = "agent/irpd_unreachable";

async function unacknowledged(page: Page): Promise<number> {
  return Number(await page.getByTestId("alarm-banner").getAttribute("data-unacknowledged"));
}

test("the banner counts a new alarm and an operator acknowledges it on the Alarms page", async ({ page }) => {
  // what earlier tests left (another stop of irpd, the cell's own alarms) acknowledged first
  expect((await api("/alarms/ack", { method: "POST" }, "operator")).status).toBe(200);
  await signIn(page, "operator", "#/schedule");
  const banner = page.getByTestId("alarm-banner");
  await expect(banner).not.toHaveText(/not connected/, { timeout: 30_000 });
  const before = await unacknowledged(page);

  const irpd = server().pids.irpd;
  process.kill(irpd, "SIGSTOP");
  try {
    await expect.poll(() => unacknowledged(page), { timeout: 60_000 }).toBeGreaterThan(before);
    await expect(banner).toContainText("unacknowledged");
    await expect(banner).toHaveClass(/bad/); // irpd unreachable is high
    await shot(page, "alarm-banner");
  } finally {
    process.kill(irpd, "SIGCONT");
  }

  await page.goto(`${server().url}/#/overview`);
  await expect(page.getByTestId("newest-alarm")).not.toContainText("none needs attention", { timeout: 30_000 });
  await shot(page, "overview-newest-alarm");
  await banner.click();
  await expect(page.getByTestId("alarms-page")).toBeVisible();
  const row = page.getByTestId(`alarm-${KEY}`);
  await expect(row).toBeVisible();
  await expect(row).toContainText("irpd does not answer");
  await shot(page, "alarms");
  await page.getByTestId(`ack-${KEY}`).click();
  await expect(page.getByTestId(`ack-${KEY}`)).toHaveCount(0, { timeout: 30_000 });
  await expect(page.getByTestId("alarm-history")).toContainText("acknowledge", { timeout: 30_000 });
  // the banner counts what the agent counts (the cell may raise its own alarms meanwhile)
  const agentCount = async () =>
    ((await (await api("/alarms")).json()) as { counts: { unacknowledged: number } }).counts;
  await expect
    .poll(async () => (await unacknowledged(page)) === (await agentCount()).unacknowledged, { timeout: 30_000 })
    .toBe(true);
  const history = await api(`/alarms/history?key=${encodeURIComponent(KEY)}&limit=5`);
  const last = ((await history.json()) as { transitions: { event: string; who: { name: string } | null }[] })
    .transitions;
  // the person who acknowledged, signed in by name (not a token's name)
  const operator = server().users.operator.name;
  expect(last.find((t) => t.event === "acknowledge")?.who?.name).toBe(operator);

  const audit = (await (await api("/audit?limit=50")).json()) as {
    action: string;
    target: string;
    who: { name: string; via: string };
  }[];
  const ack = audit.filter((e) => e.action === "alarm_ack" && e.target === KEY);
  expect(ack.at(-1)?.who).toMatchObject({ name: operator, via: "session" });
});

test("a viewer sees the alarms but no buttons", async ({ page }) => {
  await signIn(page, "viewer", "#/alarms");
  await expect(page.getByTestId("alarm-list")).toBeVisible();
  await expect(page.getByTestId("ack-all")).toHaveCount(0);
  await expect(page.locator("[data-testid^=ack-]")).toHaveCount(0);
  await expect(page.getByTestId("alarm-banner")).not.toHaveText(/not connected/, { timeout: 30_000 });
});
