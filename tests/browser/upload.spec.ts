// upload.spec.ts -- uploading a set with a broken module.xml shows the agent's error with its file
// and line; nothing is stored.
import { api, expect, shot, signIn, test } from "./fixtures";

const BROKEN = `<?xml version="1.0"?>
<root>
<module>
  <filename>./x.so</filename>
  <moduletype>thread</modultype>
</module>
</root>
`;

test("a broken module.xml is refused with its line", async ({ page }) => {
  const setsBefore = (await (await api("/sets")).json()).length;
  await signIn(page, "admin", "#/modules");
  await page.locator("input[type=file]").first().setInputFiles({ name: "module.xml", mimeType: "text/xml", buffer: Buffer.from(BROKEN) });
  const error = page.getByTestId("upload-error");
  await expect(error).toContainText("module.xml");
  await expect(error).toContainText(/line 5/);
  await shot(page, "upload-error");
  expect((await (await api("/sets")).json()).length).toBe(setsBefore);
});
