// upload.test.ts -- the files of a drop (folders walked, relative paths kept), the set's root,
// the multipart body, and the refusal with its file and line.
import { describe, expect, it } from "vitest";
import { placeText } from "../../src/api/place";
import {
  buildForm,
  type EntryLike,
  filesFromEntries,
  filesFromList,
  planUpload,
  refusal,
  type UploadFile,
} from "../../src/ops/upload";

const file = (name: string, text = name) => new File([text], name);

function fileEntry(name: string): EntryLike {
  return { isFile: true, isDirectory: false, name, file: (ok) => ok(file(name)) };
}

/** A folder whose reader answers in batches of `batch`, then an empty batch, like Chromium's. */
function dirEntry(name: string, children: EntryLike[], batch = 2): EntryLike {
  return {
    isFile: false,
    isDirectory: true,
    name,
    createReader() {
      let at = 0;
      return {
        readEntries(ok) {
          const part = children.slice(at, at + batch);
          at += batch;
          setTimeout(() => ok(part), 0);
        },
      };
    },
  };
}

const up = (...paths: string[]): UploadFile[] => paths.map((p) => ({ path: p, file: file(p.split("/").pop()!) }));

describe("dropped entries", () => {
  it("walks folders, reading every batch, keeping relative paths", async () => {
    const tree = [
      dirEntry("plc-robot", [
        fileEntry("module.xml"),
        fileEntry("Robot.so"),
        fileEntry("main.so"),
        dirEntry("lib", [fileEntry("cntr1.so"), fileEntry("cntr2.so"), fileEntry("cntr3.so")]),
        fileEntry("layout.json"),
      ]),
    ];
    const files = await filesFromEntries(tree);
    expect(files.map((f) => f.path).sort()).toEqual([
      "plc-robot/Robot.so",
      "plc-robot/layout.json",
      "plc-robot/lib/cntr1.so",
      "plc-robot/lib/cntr2.so",
      "plc-robot/lib/cntr3.so",
      "plc-robot/main.so",
      "plc-robot/module.xml",
    ]);
    expect(await files[0].file.text()).toBe("module.xml");
  });

  it("loose files keep their names", async () => {
    const files = await filesFromEntries([fileEntry("module.xml"), fileEntry("cntr1.so")]);
    expect(files.map((f) => f.path)).toEqual(["module.xml", "cntr1.so"]);
  });

  it("a folder picked with <input webkitdirectory> uses webkitRelativePath", () => {
    const f = file("module.xml");
    Object.defineProperty(f, "webkitRelativePath", { value: "set/module.xml" });
    expect(filesFromList([f, file("x.so")]).map((u) => u.path)).toEqual(["set/module.xml", "x.so"]);
  });
});

describe("planUpload", () => {
  it("takes off the dropped folder so that module.xml is at the top; subfolders stay", () => {
    const plan = planUpload(up("plc-robot/lib/cntr1.so", "plc-robot/module.xml", "plc-robot/Robot.so"));
    expect(plan.kind).toBe("files");
    if (plan.kind !== "files") return;
    expect(plan.root).toBe("plc-robot/");
    expect(plan.files.map((f) => f.path)).toEqual(["module.xml", "lib/cntr1.so", "Robot.so"]);
  });

  it("takes off nested single folders too", () => {
    const plan = planUpload(up("a/b/module.xml", "a/b/x.so"));
    expect(plan.kind === "files" && plan.files.map((f) => f.path)).toEqual(["module.xml", "x.so"]);
  });

  it("leaves desktop litter out and says so", () => {
    const plan = planUpload(up("set/module.xml", "set/.DS_Store", "set/._module.xml", "set/x.so"));
    expect(plan.kind === "files" && plan.files.map((f) => f.path)).toEqual(["module.xml", "x.so"]);
    expect(plan.kind === "files" && plan.skipped).toEqual(["set/.DS_Store", "set/._module.xml"]);
  });

  it("refuses a set without module.xml at its top", () => {
    expect(planUpload(up("a/module.xml", "b/x.so"))).toMatchObject({
      kind: "error",
      message: /no module.xml at the top/,
    });
    expect(planUpload(up("x.so"))).toMatchObject({ kind: "error" });
    expect(planUpload([])).toMatchObject({ kind: "error", message: "no files" });
  });

  it("one .tar.gz goes alone as the archive", () => {
    expect(planUpload(up("dl/set.tar.gz"))).toMatchObject({ kind: "archive", name: "set.tar.gz" });
    expect(planUpload(up("set.tgz"))).toMatchObject({ kind: "archive" });
    expect(planUpload(up("set.tar.gz", "module.xml"))).toMatchObject({
      kind: "error",
      message: /send an archive alone/,
    });
  });
});

describe("multipart body", () => {
  it("one `files` part per file, its filename the path in the set", () => {
    const plan = planUpload(up("s/module.xml", "s/lib/cntr2.so"));
    if (plan.kind === "error") throw new Error(plan.message);
    const form = buildForm(plan);
    const parts = form.getAll("files") as File[];
    expect(parts.map((p) => p.name)).toEqual(["module.xml", "lib/cntr2.so"]);
    expect(form.has("archive")).toBe(false);
  });

  it("an archive as the `archive` part", () => {
    const plan = planUpload(up("x/set.tar.gz"));
    if (plan.kind === "error") throw new Error(plan.message);
    const form = buildForm(plan);
    expect((form.get("archive") as File).name).toBe("set.tar.gz");
    expect(form.has("files")).toBe(false);
  });
});

describe("refusals", () => {
  it("carry file, line and column when the agent names them", () => {
    const r = refusal(400, {
      detail: "module 'x': <period>: 'abc' is not a number",
      file: "module.xml",
      line: 12,
      column: 5,
    });
    expect(r).toEqual({
      status: 400,
      message: "module 'x': <period>: 'abc' is not a number",
      file: "module.xml",
      line: 12,
      column: 5,
    });
    expect(placeText(r)).toBe("module.xml:12:5");
    expect(placeText(refusal(400, { detail: "d", file: "a.so" }))).toBe("a.so");
    expect(placeText(refusal(413, { detail: "too large" }))).toBe("");
  });

  it("names the module and the module.xml field from their fields, never from the message", () => {
    const r = refusal(409, {
      detail: "irpd refused the set: elsewhere.xml:99: something",
      file: "module.xml",
      line: 7,
      column: 5,
      module: "cntr1",
      field: "property.restart",
    });
    expect(placeText(r)).toBe("module.xml:7:5 (module cntr1, <property.restart>)");
    expect(placeText(refusal(409, { detail: "d", module: "io" }))).toBe("module io");
    expect(placeText(refusal(409, { detail: "d", line: 3, field: "period" }))).toBe("line 3 (<period>)");
  });

  it("say when the agent did not answer or the upload was cancelled", () => {
    expect(refusal(0, "").message).toMatch(/did not answer/);
    expect(refusal(0, "aborted").message).toBe("upload cancelled");
    expect(refusal(502, "Bad Gateway").message).toBe("Bad Gateway");
  });
});
