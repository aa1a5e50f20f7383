// plot-bench.mjs -- the browser half of tests/bench/plot_bench.py: Debian's chromium (headless, via Playwright)
// opens the UI at `url`, first a page with no plot (the reference), then the Variables page plotting
// `paths`, and reports frame intervals and samples as JSON on stdout.  It signs in through the form
// with a user's name and password.
//   node plot-bench.mjs URL USER PASSWORD SECONDS PATH...
import { chromium } from "@playwright/test";

const [url, user, password, seconds, ...paths] = process.argv.slice(2);
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  // 2D canvases are drawn by Skia on the CPU (no GPU here); a software GL (SwiftShader) for them is far slower
  args: (process.env.CHROMIUM_ARGS ?? "--disable-gpu --no-sandbox").split(" ").filter(Boolean),
});
const page = await browser.newPage({ viewport: { width: 1440, height: 900 } });

// Frame intervals as the page sees them: one requestAnimationFrame callback per frame.
async function frameIntervals(ms) {
  return page.evaluate(
    (ms) =>
      new Promise((resolve) => {
        const t = [];
        const end = performance.now() + ms;
        const tick = (now) => {
          t.push(now);
          if (now < end) requestAnimationFrame(tick);
          else resolve(t.slice(1).map((x, i) => x - t[i]));
        };
        requestAnimationFrame(tick);
      }),
    ms,
  );
}

await page.goto(`${url}/#/overview`);
await page.getByTestId("user-name").fill(user);
await page.getByTestId("password").fill(password);
await page.getByTestId("sign-in").click();
await page.getByTestId("who").waitFor();
const reference = await frameIntervals(10_000);

await page.goto(`${url}/#/variables?plot=${encodeURIComponent(paths.join(","))}`);
await page.getByTestId("plot-panel-1").waitFor();
await page.waitForFunction((n) => (window.__induropPlotStats?.samples ?? 0) > n, 100);
const cycles = async () => (await (await page.request.get(`${url}/api/v1/status`)).json()).cycles; // the page's session
const cyclesBefore = await cycles();
const before = await page.evaluate(() => ({ ...window.__induropPlotStats, dropped: Number(document.querySelector("[data-testid=drop-counter]")?.textContent?.match(/\d+/)?.[0] ?? -1) }));
const plot = await frameIntervals(Number(seconds) * 1000);
const cyclesAfter = await cycles();
const after = await page.evaluate(() => ({ ...window.__induropPlotStats, dropped: Number(document.querySelector("[data-testid=drop-counter]")?.textContent?.match(/\d+/)?.[0] ?? -1) }));
await page.screenshot({ path: process.env.SHOT ?? "/tmp/plot-bench.png" });
await browser.close();
console.log(JSON.stringify({ reference, plot, before: strip(before), after: strip(after), cycles: cyclesAfter - cyclesBefore }));

function strip(s) {
  const { frameTimes, frameIntervals, ...rest } = s;
  return { ...rest, workMsRecent: (frameTimes ?? []).slice(-600) };
}
