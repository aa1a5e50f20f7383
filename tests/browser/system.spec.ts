// system.spec.ts -- the System page as an admin sees it: the agent's and irpd's versions, the data
// folder and the certificate line; the agent's log shown and searched; a backup downloaded and checked by
// a restore's dry run (its review shown, then cancelled); the prune's dry run; a restart asked for
// and cancelled (the suite's one irpd keeps running).  A viewer has no System page.  The OPC UA page: a
// client application's certificate (left in pki/rejected, as the server does) trusted by an admin.
import { spawnSync } from "node:child_process";
import { mkdirSync, readFileSync } from "node:fs";
import { join } from "node:path";
import { api, expect, server, shot, signIn, test } from "./fixtures";
import { ROOT } from "./server";

test("an admin sees the system's figures, its logs, a backup's review and the prune's dry run", async ({ page }) => {
  await signIn(page, "admin", "#/system");
  await expect(page.getByTestId("system-page")).toBeVisible();
  const system = (await (await api("/system")).json()) as { agent: { version: string }; irpd: { pid: number } };
  await expect(page.getByTestId("agent-version")).toContainText(system.agent.version);
  await expect(page.getByTestId("irpd-version")).toContainText(`pid ${system.irpd.pid}`);
  await expect(page.getByTestId("data-used")).toContainText("used");
  await expect(page.getByTestId("tls-subject")).toContainText("plain HTTP");
  await expect(page.getByTestId("log-sources")).toContainText("irpd.log");

  // the agent's log (the file serve.py has it write: its start lines at least), then searched
  await page.getByTestId("log-select").selectOption("agent");
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-lines-view")).toContainText("indurop-agent");
  const shown = await page.getByTestId("log-lines-view").locator(".ops-log-line").count();
  await page.getByTestId("log-grep").fill("INDUROP-AGENT"); // any case
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-info")).toContainText(/, [1-9]\d* line\(s\)/);
  const found = await page.getByTestId("log-lines-view").locator(".ops-log-line").count();
  expect(found).toBeGreaterThan(0);
  expect(found).toBeLessThanOrEqual(shown);
  await page.getByTestId("log-grep").fill("no line holds this text 1f2e3d");
  await page.getByTestId("log-show").click();
  await expect(page.getByTestId("log-info")).toContainText(", 0 line(s)");
  await page.getByTestId("log-grep").fill("");

  // a backup downloaded, then reviewed by a restore's dry run; the restore itself is cancelled
  const [download] = await Promise.all([page.waitForEvent("download"), page.getByTestId("backup-download").click()]);
  expect(download.suggestedFilename()).toMatch(/^indurop-backup-.*\.tar\.gz$/);
  const file = await download.path();
  expect(readFileSync(file).subarray(0, 2)).toEqual(Buffer.from([0x1f, 0x8b])); // gzip
  await page.getByTestId("restore-file").setInputFiles(file);
  await page.getByTestId("restore-check").click();
  await expect(page.getByTestId("restore-plan")).toContainText("already here");
  await expect(page.getByTestId("restore-files")).toContainText("tokens.json");
  await expect(page.getByTestId("restore-confirm")).toBeVisible();
  await shot(page, "system-restore-review");
  await page.getByTestId("restore-confirm-no").click();
  await expect(page.getByTestId("restore-confirm")).toBeHidden();

  // the prune's dry run: a report, deleting nothing
  const before = ((await (await api("/sets")).json()) as unknown[]).length;
  await page.getByTestId("prune-keep").fill("1000");
  await page.getByTestId("prune-dry-run").click();
  await expect(page.getByTestId("prune-report")).toContainText("would delete 0 set(s)");
  expect(((await (await api("/sets")).json()) as unknown[]).length).toBe(before);

  // a restart is asked for before it is sent
  await page.getByTestId("restart-irpd").click();
  await expect(page.getByTestId("restart-confirm")).toContainText("safe values");
  await shot(page, "system");
  await page.getByTestId("restart-confirm-no").click();
  await expect(page.getByTestId("restart-confirm")).toBeHidden();
});

test("a viewer has no System page: not in the menu, its address shows the Overview, its API refuses", async ({
  page,
}) => {
  await signIn(page, "viewer", "#/system");
  await expect(page.locator("nav a[data-page=overview]")).toBeVisible();
  await expect(page.locator("nav a[data-page=system]")).toHaveCount(0);
  await expect(page.locator("main[data-page=overview]")).toBeVisible();
  expect((await api("/system", {}, "viewer")).status).toBe(403);
});

test("an admin trusts a rejected OPC UA client certificate on the OPC UA page", async ({ page }) => {
  // a client's certificate where the OPC UA server leaves an unknown one (this suite runs no server)
  const rejected = join(server().work, "data", "viser", "opcua", "pki", "rejected");
  mkdirSync(rejected, { recursive: true });
  const made = spawnSync(join(ROOT, ".venv/bin/python"), ["-c", MAKE_CERT, join(rejected, "scada.der")], {
    encoding: "utf8",
  });
  expect(made.status, made.stderr).toBe(0);
  const sha1 = made.stdout.trim();
  await signIn(page, "admin", "#/opcua");
  await expect(page.getByTestId("opcua-notice")).toContainText("has not run");
  const row = page.getByTestId(`opcua-cert-${sha1}`);
  await expect(row).toHaveAttribute("data-folder", "rejected");
  await expect(row).toContainText("urn:plant:scada");
  await page.getByTestId(`opcua-trust-${sha1}`).click();
  await expect(page.getByTestId("opcua-confirm")).toContainText("Trust urn:plant:scada?");
  await shot(page, "opcua");
  await page.getByTestId("opcua-confirm-yes").click();
  await expect(page.getByTestId("opcua-result")).toContainText("moved to trusted/scada.der");
  await expect(page.getByTestId(`opcua-cert-${sha1}`)).toHaveAttribute("data-folder", "trusted");
  const state = (await (await api("/opcua")).json()) as { trusted: { sha1: string }[] };
  expect(state.trusted.map((c) => c.sha1)).toContain(sha1);
  await page.getByTestId(`opcua-remove-${sha1}`).click();
  await page.getByTestId("opcua-confirm-yes").click();
  await expect(page.getByTestId(`opcua-cert-${sha1}`)).toHaveCount(0);
});

// a self-signed client application certificate (DER) at argv[1]; prints its SHA-1 thumbprint
const MAKE_CERT = `
import datetime, hashlib, sys
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID
key = ec.generate_private_key(ec.SECP256R1())
name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "SCADA")])
now = datetime.datetime.now(datetime.timezone.utc)
cert = (x509.CertificateBuilder().subject_name(name).issuer_name(name).public_key(key.public_key())
        .serial_number(x509.random_serial_number()).not_valid_before(now - datetime.timedelta(days=1))
        .not_valid_after(now + datetime.timedelta(days=365))
        .add_extension(x509.SubjectAlternativeName([x509.UniformResourceIdentifier("urn:plant:scada")]), False)
        .sign(key, hashes.SHA256()))
der = cert.public_bytes(serialization.Encoding.DER)
open(sys.argv[1], "wb").write(der)
print(hashlib.sha1(der).hexdigest())
`;
