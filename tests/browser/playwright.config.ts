// playwright.config.ts -- the browser tests: Debian's chromium (headless, WebGL by SwiftShader),
// against a real irpd + agent started by global-setup.ts.  Screenshots and traces land in
// build/test-artifacts/browser/.

import { join } from "node:path";
import { defineConfig } from "@playwright/test";

const artifacts = join(__dirname, "../../build/test-artifacts/browser");

export default defineConfig({
  testDir: ".",
  testMatch: /.*\.spec\.ts$/,
  testIgnore: /bench\//,
  outputDir: join(artifacts, "results"),
  globalSetup: "./global-setup.ts",
  timeout: 120_000,
  // An assertion waits up to 15 s for the page to agree (Playwright's default is 5 s): on a loaded
  // 2-CPU machine a poll, a stream's frame or a re-render can come later than that; what is asserted
  // is the same.
  expect: { timeout: 15_000 },
  workers: 1, // the specs share one irpd + agent and its set (global-setup.ts)
  retries: 0,
  reporter: [
    ["list"],
    ["html", { outputFolder: join(artifacts, "report"), open: "never" }],
    // for the slowest tests tests/run.sh lists (tests/slowest.py)
    ["junit", { outputFile: join(__dirname, "../../build/test-results/playwright.xml") }],
  ],
  use: {
    headless: true,
    viewport: { width: 1440, height: 900 },
    screenshot: "on",
    trace: "retain-on-failure",
    launchOptions: {
      executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
      args: ["--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"],
    },
  },
});
