// upload-st.test.ts -- a set written in Structured Text: its .st files make the top of the set, and an
// upload the compiler refuses shows every error on its line (main.st:6:9 error[type]: ...) in the panel.
import { afterEach, describe, expect, it, vi } from "vitest";
import type { AppContext } from "../../src/app/context";
import { planUpload, refusal, type UploadFile } from "../../src/ops/upload";
import { UploadPanel } from "../../src/ops/upload-panel";

const up = (...paths: string[]): UploadFile[] => paths.map((p) => ({ path: p, file: new File([p], p) }));

const REFUSED = {
  detail: "the set's ST sources do not compile (2 errors):\nmain.st:6:9: error[type]: cannot assign DINT to BOOL",
  file: "main.st",
  line: 6,
  column: 9,
  problems: [
    { message: "cannot assign DINT to BOOL; use DINT_TO_BOOL(...)", code: "type", file: "main.st", line: 6, column: 9 },
    { message: "expected an expression, found ';'", code: "syntax", file: "lib/util.st", line: 3, column: 18 },
  ],
};

/** An XMLHttpRequest that answers every request with `status` and `body`. */
function answering(status: number, body: unknown) {
  return class {
    status = 0;
    responseText = "";
    upload = { onprogress: null };
    onload: (() => void) | null = null;
    onerror: (() => void) | null = null;
    onabort: (() => void) | null = null;
    open() {}
    setRequestHeader() {}
    abort() {}
    send() {
      this.status = status;
      this.responseText = JSON.stringify(body);
      setTimeout(() => this.onload?.(), 0);
    }
  };
}

afterEach(() => vi.unstubAllGlobals());

describe("a set in Structured Text", () => {
  it("has its top where its .st files are, with or without module.xml", () => {
    const plan = planUpload(up("plc/main.st", "plc/config.st", "plc/lib/util.st"));
    expect(plan.kind === "files" && plan.files.map((f) => f.path).sort()).toEqual([
      "config.st",
      "lib/util.st",
      "main.st",
    ]);
    expect(planUpload(up("a/lib/util.st", "b/x.so"))).toMatchObject({ kind: "error", message: /nor .st or PLCopen/ });
  });

  it("a PLCopen XML project alone is a set's top too (the agent tells it from another .xml)", () => {
    const plan = planUpload(up("project/plc.xml", "project/notes/readme.txt"));
    expect(plan.kind === "files" && plan.files.map((f) => f.path).sort()).toEqual(["notes/readme.txt", "plc.xml"]);
    expect(planUpload(up("plc.xml"))).toMatchObject({ kind: "files", root: "" });
  });

  it("a refusal keeps every compile error with its place and code", () => {
    const r = refusal(400, REFUSED);
    expect(r).toMatchObject({ file: "main.st", line: 6, column: 9 });
    expect(r.problems).toEqual([
      { message: REFUSED.problems[0].message, code: "type", file: "main.st", line: 6, column: 9 },
      { message: REFUSED.problems[1].message, code: "syntax", file: "lib/util.st", line: 3, column: 18 },
    ]);
    expect(refusal(400, { detail: "d", problems: "no" }).problems).toBeUndefined();
  });

  it("the upload panel shows each error on its line", async () => {
    vi.stubGlobal("XMLHttpRequest", answering(400, REFUSED));
    const notify = vi.fn();
    const ctx = { session: { csrf: "t" }, notify } as unknown as AppContext;
    const panel = new UploadPanel(
      ctx,
      () => {},
      () => null,
    );
    document.body.append(panel.element);
    await panel.upload(up("main.st", "config.st", "lib/util.st"));
    const shown = [...panel.element.querySelectorAll('[data-testid="upload-error"] [data-testid="problem"]')].map(
      (li) => li.textContent,
    );
    expect(shown).toEqual([
      "main.st:6:9: error[type]: cannot assign DINT to BOOL; use DINT_TO_BOOL(...)",
      "lib/util.st:3:18: error[syntax]: expected an expression, found ';'",
    ]);
    const head = panel.element.querySelector('[data-testid="upload-error"] div')?.textContent;
    expect(head).toBe("Refused (HTTP 400) main.st:6:9: the set's ST sources do not compile (2 errors):");
    expect(notify).toHaveBeenCalledWith(expect.stringMatching(/^upload refused: main.st:6:9: /), "error");
    panel.element.remove();
  });
});
