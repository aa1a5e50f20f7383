// io-load-pages.mjs -- the browser half of tests/bench/io_load.py: Debian's chromium (headless, via
// Playwright) signs in and keeps the Robot page (the 3D view) and the Variables page (plotting
// `paths`) open for SECONDS, as an operator's browser on the controller's own screen would.
// Prints one JSON line when done: the frames each page drew and the console errors seen.  It signs
// in through the form with a user's name and password.
//   node io-load-pages.mjs URL USER PASSWORD SECONDS PATH...
import { chromium } from "@playwright/test";

const [url, user, password, seconds, ...paths] = process.argv.slice(2);
const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  args: (process.env.CHROMIUM_ARGS ?? "--disable-gpu --no-sandbox").split(" ").filter(Boolean),
});
const context = await browser.newContext({ viewport: { width: 1440, height: 900 } });
const errors = [];

async function open(hash) {
  const page = await context.newPage();
  page.on("console", (m) => m.type() === "error" && errors.push(`${hash}: ${m.text()}`));
  await page.goto(`${url}/${hash}`);
  // the form, or the shell when the context's session cookie signs the page in (the second page)
  await page.locator("[data-testid=who], [data-testid=user-name]").first().waitFor();
  if (await page.getByTestId("user-name").isVisible()) {
    await page.getByTestId("user-name").fill(user);
    await page.getByTestId("password").fill(password);
    await page.getByTestId("sign-in").click();
  }
  await page.getByTestId("who").waitFor();
  await page.goto(`${url}/${hash}`);
  return page;
}

// Frames a page drew over `ms`: one requestAnimationFrame callback per frame.
const frames = (page, ms) =>
  page.evaluate(
    (ms) =>
      new Promise((resolve) => {
        let n = 0;
        const end = performance.now() + ms;
        const tick = (now) => (++n, now < end ? requestAnimationFrame(tick) : resolve(n));
        requestAnimationFrame(tick);
      }),
    ms,
  );

const robot = await open("#/robot");
const variables = await open(`#/variables?plot=${encodeURIComponent(paths.join(","))}`);
console.error("io-load-pages: the robot and variables pages are open");
const ms = Number(seconds) * 1000;
const [robotFrames, variablesFrames] = await Promise.all([frames(robot, ms), frames(variables, ms)]);
await browser.close();
console.log(JSON.stringify({ robotFrames, variablesFrames, seconds: Number(seconds), errors }));
