import { readFileSync } from "node:fs";
import { expect, shot, signIn, test } from "./fixtures";
import { startServer, stopServer } from "./server";
import { rest } from "./st_cell";

const MAIN = `PROGRAM Counter\nVAR\n  count : DINT;\nEND_VAR\ncount := count + 1;\nEND_PROGRAM\n`;
const CONF = `CONFIGURATION Cell\n  RESOURCE Cpu ON PLC\n    TASK Fast (INTERVAL := T#1ms, PRIORITY := 1);\n    PROGRAM Main WITH Fast : Counter;\n  END_RESOURCE\nEND_CONFIGURATION\n`;
for (const [proj, pou] of [
  ["tutorial_xor_xnor", "XOR_and_XNOR"],
  ["openplc_blink", "Blink"],
  ["beremiz_first_steps", "CounterSFC"],
  ["beremiz_first_steps", "plc_prg"],
  ["beremiz4uc_traffic_lights", "traffic_light_sequence"],
  ["openplc_multi_language", "CounterLD"],
  ["beremiz_iec61131_lang_test", "TEMPO_TEST"],
]) {
  test(`dev ${proj} ${pou}`, async ({ page }) => {
    test.setTimeout(300_000);
    const s = await startServer();
    try {
      const form = new FormData();
      form.append("files", new Blob([readFileSync(`/work/shared/plcopen/${proj}/plc.xml`)]), "plc.xml");
      form.append("files", new Blob([MAIN]), "main.st");
      form.append("files", new Blob([CONF]), "config.st");
      const r = await rest(s, "/sets", { method: "POST", body: form });
      expect(r.status, await r.clone().text()).toBe(201);
      const id = (await r.json()).id;
      await rest(s, `/sets/${id}/activate`, {
        method: "POST",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify({ mode: "auto" }),
      });
      await signIn(page, "admin", "#/programs", s);
      await page.getByTestId(`st-pou-${pou}`).click();
      await expect(page.getByTestId("pl-svg")).toBeVisible();
      await page.getByTestId("st-monitor").click();
      await page.waitForTimeout(1000);
      await shot(page, `dev-${pou}`);
    } finally {
      await stopServer(s);
    }
  });
}
