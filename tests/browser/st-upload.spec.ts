// st-upload.spec.ts -- a set written in Structured Text uploaded from the browser (docs/st.md, issue 29's
// "Done when"): the Modules page's upload compiles it on the appliance, it is activated and runs, its
// variables are on the Variables page and in the Scope's picker with their IEC types beside the C++
// ones, and an OPC UA client reads them (tests/browser/opcua_read.py, asyncua); an upload the compiler
// refuses shows the error on its line and leaves the running set running.  A server of its own (irpd
// on the paper's Figure 1 set, the agent, indurop-opcua), so that the suite's cell is not changed.
import { execFileSync } from "node:child_process";
import { join } from "node:path";
import { expect, shot, signIn, test } from "./fixtures";
import { PYTHON, ROOT, type Server, startServer, stopServer } from "./server";

const FIG1 = join(ROOT, "build/sets/paper-fig1/module.xml");
const COUNTER = `PROGRAM Counter
VAR
  count : DINT;
  elapsed : TIME;
END_VAR
count := count + 1;
elapsed := elapsed + T#1ms;
END_PROGRAM
`;
const CONFIG = `CONFIGURATION Cell
  RESOURCE Cpu ON PLC
    TASK Fast (INTERVAL := T#1ms, PRIORITY := 1);
    PROGRAM Main WITH Fast : Counter;
  END_RESOURCE
END_CONFIGURATION
`;
// line 6, column 9: a DINT assigned to a BOOL
const TYPE_ERROR = "PROGRAM Counter\nVAR\n  count : DINT;\n  flag : BOOL;\nEND_VAR\nflag := count;\nEND_PROGRAM\n";

const st = (main: string) => [
  { name: "main.st", mimeType: "text/plain", buffer: Buffer.from(main) },
  { name: "config.st", mimeType: "text/plain", buffer: Buffer.from(CONFIG) },
];

async function rest(s: Server, path: string): Promise<Response> {
  return fetch(`${s.url}/api/v1${path}`, { headers: { Authorization: `Bearer ${s.tokens.admin}` } });
}

async function countOf(s: Server): Promise<number> {
  return (await (await rest(s, "/variables/Main.count")).json()).value;
}

test("an ST set uploaded from the browser runs, its variables show their IEC types and OPC UA reads them; a type error is shown on its line and the set runs on", async ({
  page,
}) => {
  test.setTimeout(300_000); // the appliance compiles the set (stc, then the C++ compiler)
  const s = await startServer(FIG1, { opcua: true });
  try {
    await signIn(page, "admin", "#/modules", s);
    await page.getByTestId("upload-files").setInputFiles(st(COUNTER));
    const result = page.getByTestId("upload-result");
    await expect(result.getByTestId("upload-set-id")).not.toBeEmpty({ timeout: 180_000 });
    const id = (await result.getByTestId("upload-set-id").textContent()) ?? "";
    const plan = result.getByTestId("plan");
    await expect(plan.getByTestId("plan-activate")).toBeVisible();
    const confirm = plan.getByTestId("plan-restart-confirm");
    if (await confirm.count()) await confirm.check(); // Figure 1's layout is not the ST set's
    await plan.getByTestId("plan-activate").click();
    await expect(page.getByTestId("swap-report").last()).toBeVisible({ timeout: 60_000 });
    await expect.poll(async () => (await (await rest(s, "/status")).json()).set_id, { timeout: 30_000 }).toBe(id);
    await shot(page, "st-upload-activated");

    // it runs: the counter counts, on the Variables page with its IEC type beside the C++ one
    await page.goto(`${s.url}/#/variables`);
    await page.getByTestId("var-search").fill("Main.");
    const count = page.getByTestId("var-Main.count");
    await expect(count.locator(".type")).toHaveText("DINT (int32_t)");
    await expect(page.getByTestId("var-Main.elapsed").locator(".type")).toHaveText("TIME (int64_t)");
    const shown = async () => Number(await page.getByTestId("value-Main.count").textContent()); // NaN until read
    await expect.poll(shown).toBeGreaterThan(0);
    const first = await shown();
    await expect.poll(shown).toBeGreaterThan(first);
    await shot(page, "st-upload-variables");

    // the Scope's picker offers it with its types
    await page.goto(`${s.url}/#/scope`);
    await expect(page.locator('#scope-all-paths option[value="Main.count"]')).toHaveAttribute(
      "label",
      "DINT (int32_t)",
    );
    await expect(page.locator('#scope-all-paths option[value="Main.elapsed"]')).toHaveAttribute(
      "label",
      "TIME (int64_t)",
    );

    // an OPC UA client reads it, its node describing the IEC type
    const viewer = s.users.viewer;
    const opcua = s.opcua!;
    const read = () =>
      JSON.parse(
        execFileSync(
          PYTHON,
          [
            join(__dirname, "opcua_read.py"),
            opcua.url,
            opcua.data,
            viewer.name,
            viewer.password,
            "Main.count",
            "Main.elapsed",
          ],
          { encoding: "utf8", timeout: 90_000 },
        ),
      );
    let nodes = read();
    for (let i = 0; i < 50 && !(nodes["Main.count"].value > 0); i++) nodes = read(); // the server's tree follows the set
    expect(nodes["Main.count"].value).toBeGreaterThan(0);
    expect(nodes["Main.count"].description).toBe("DINT (int32_t) Main.count");
    expect(nodes["Main.elapsed"].description).toBe("TIME (int64_t) Main.elapsed");

    // an upload the compiler refuses: the error on its line, nothing stored, the set runs on
    const setsBefore = (await (await rest(s, "/sets")).json()).length;
    await page.goto(`${s.url}/#/modules`);
    await page.getByTestId("upload-files").setInputFiles(st(TYPE_ERROR));
    const error = page.getByTestId("upload-error");
    await expect(error.getByTestId("problem").first()).toContainText(
      "main.st:6:9: error[type]: cannot assign DINT to BOOL",
      {
        timeout: 120_000,
      },
    );
    await shot(page, "st-upload-refused");
    expect((await (await rest(s, "/sets")).json()).length).toBe(setsBefore);
    expect((await (await rest(s, "/status")).json()).set_id).toBe(id);
    const before = await countOf(s);
    await expect.poll(() => countOf(s)).toBeGreaterThan(before);
  } finally {
    await stopServer(s);
  }
});
