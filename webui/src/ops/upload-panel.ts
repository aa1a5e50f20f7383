// upload-panel.ts -- uploading a set (admin): drop its folder, its files or one .tar.gz (or pick
// them), watch the upload's progress, read irpd's validation of the stored set or the refusal
// with its file and line; then the activation review (what activating it would change, one button).

import { placeText } from "../api/place";
import type { AppContext } from "../app/context";
import { h, setText } from "./dom";
import { problemList } from "./problems-view";
import { renderSlotTable } from "./slot-table-view";
import { buildSlotTable } from "./timeline";
import type { Schedule, SetPublic } from "./types";
import { formatBytes } from "./units";
import {
  buildForm,
  filesFromDrop,
  filesFromList,
  planUpload,
  type Refusal,
  refusal,
  send,
  type UploadFile,
  type UploadHandle,
} from "./upload";

export class UploadPanel {
  readonly element: HTMLElement;
  private progress = h("progress", { max: 1, value: 0, "data-testid": "upload-progress" });
  private progressText = h("span", { class: "ops-sub num" });
  private progressRow: HTMLElement;
  private cancel = h("button", { class: "small", "data-testid": "upload-cancel" }, "cancel");
  private error = h("div", {
    class: "ops-error ops-upload-error",
    "data-testid": "upload-error",
    hidden: true,
    role: "alert",
  });
  private result = h("div", { class: "ops-upload-result", "data-testid": "upload-result", hidden: true });
  private current: UploadHandle | null = null;

  constructor(
    private readonly ctx: AppContext,
    private readonly onStored: (set: SetPublic) => void,
    private readonly renderActivate: (id: string, onClose: () => void) => HTMLElement | null,
  ) {
    const pickFiles = h("input", { type: "file", multiple: true, hidden: true, "data-testid": "upload-files" });
    const pickFolder = h("input", { type: "file", hidden: true, "data-testid": "upload-folder" });
    pickFolder.setAttribute("webkitdirectory", "");
    const drop = h(
      "div",
      { class: "ops-drop", "data-testid": "upload-drop", tabindex: 0 },
      h("strong", {}, "Drop a set here"),
      h(
        "span",
        {},
        " — its folder, its files (module.xml and every file it names, and .st or PLCopen XML sources: compiled here), or one .tar.gz. ",
      ),
      h("button", { class: "small", onclick: () => pickFiles.click() }, "choose files…"),
      " ",
      h("button", { class: "small", onclick: () => pickFolder.click() }, "choose a folder…"),
      pickFiles,
      pickFolder,
    );
    pickFiles.addEventListener("change", () => {
      if (pickFiles.files?.length) void this.upload(filesFromList(pickFiles.files));
      pickFiles.value = "";
    });
    pickFolder.addEventListener("change", () => {
      if (pickFolder.files?.length) void this.upload(filesFromList(pickFolder.files));
      pickFolder.value = "";
    });
    drop.addEventListener("dragover", (e) => {
      e.preventDefault();
      if (e.dataTransfer) e.dataTransfer.dropEffect = "copy";
      drop.classList.add("over");
    });
    drop.addEventListener("dragleave", () => drop.classList.remove("over"));
    drop.addEventListener("drop", (e) => {
      e.preventDefault();
      drop.classList.remove("over");
      if (!e.dataTransfer) return;
      const dt = e.dataTransfer;
      void filesFromDrop(dt).then(
        (files) => this.upload(files),
        (err) => this.fail({ status: 0, message: `could not read the dropped files: ${String(err)}` }),
      );
    });
    this.cancel.addEventListener("click", () => this.current?.abort());
    this.progressRow = h(
      "div",
      { class: "ops-progress", hidden: true },
      this.progress,
      " ",
      this.progressText,
      " ",
      this.cancel,
    );
    this.element = h(
      "section",
      { class: "panel ops-panel", "data-testid": "upload" },
      h(
        "h3",
        {},
        "Upload a set",
        h("span", { class: "ops-sub" }, " — stored and checked by irpd; activating it is a separate step"),
      ),
      drop,
      this.progressRow,
      this.error,
      this.result,
    );
  }

  private fail(r: Refusal): void {
    this.error.hidden = false;
    const where = placeText(r);
    this.error.replaceChildren(
      h(
        "div",
        {},
        h("strong", {}, r.status ? `Refused (HTTP ${r.status})` : "Upload failed"),
        where ? h("span", { class: "mono", "data-testid": "upload-error-where" }, ` ${where}`) : null,
        h("span", {}, `: ${r.problems?.length ? r.message.split("\n")[0] : r.message}`),
      ),
      // several errors (the ST compiler's): each on its line, with its place
      ...(r.problems?.length ? [problemList({ errors: [], problems: r.problems })] : []),
    );
  }

  /** Uploads `files` (from a drop or a picker). */
  async upload(files: UploadFile[]): Promise<void> {
    if (this.current) return;
    this.error.hidden = true;
    this.result.hidden = true;
    const plan = planUpload(files);
    if (plan.kind === "error") return this.fail({ status: 0, message: plan.message });
    const what =
      plan.kind === "archive"
        ? `archive ${plan.name}`
        : `${plan.files.length} file${plan.files.length === 1 ? "" : "s"}${plan.root ? ` from ${plan.root}` : ""}${plan.skipped.length ? ` (left out: ${plan.skipped.join(", ")})` : ""}`;
    this.progressRow.hidden = false;
    this.progress.max = Math.max(1, plan.bytes);
    this.progress.value = 0;
    setText(this.progressText, `${what}: 0 of ${formatBytes(plan.bytes)}`);
    this.cancel.hidden = false;
    this.current = send("api/v1/sets", this.ctx.session.csrf, buildForm(plan), (sent, total) => {
      const t = total || plan.bytes || 1;
      this.progress.max = t;
      this.progress.value = Math.min(sent, t);
      setText(
        this.progressText,
        sent >= t
          ? `${what}: ${formatBytes(t)} sent; irpd is checking the set…`
          : `${what}: ${formatBytes(sent)} of ${formatBytes(t)} (${Math.round((sent / t) * 100)} %)`,
      );
    });
    const { status, body } = await this.current.done;
    this.current = null;
    this.cancel.hidden = true;
    if (status !== 201 && status !== 200) {
      this.progressRow.hidden = true;
      const r = refusal(status, body);
      this.fail(r);
      this.ctx.notify(`upload refused: ${placeText(r) ? `${placeText(r)}: ` : ""}${r.message}`, "error");
      return;
    }
    this.progress.value = this.progress.max;
    const set = body as SetPublic;
    setText(this.progressText, `${what}: stored as set ${set.id}`);
    this.showResult(set);
    this.ctx.notify(`set ${set.id} stored (${set.files.length} files)`);
    this.onStored(set);
  }

  private showResult(set: SetPublic): void {
    const v = set.validation;
    const verdict =
      v.valid === true
        ? v.online === false
          ? "valid; only a restart of irpd can run it"
          : "valid"
        : v.valid === false
          ? "NOT valid: irpd will refuse to activate it"
          : "not checked (irpd did not answer)";
    const cls = v.valid === true ? "good" : v.valid === false ? "bad" : "warn";
    const schedule = v.schedule ? (v.schedule as unknown as Schedule) : null;
    // the review shows the slot table now and after beside the variable diff; without one, the set's own table
    const review: HTMLElement | null =
      !set.active && v.valid !== false ? this.renderActivate(set.id, () => review?.remove()) : null;
    this.result.hidden = false;
    // h() leaves out the parts that are null
    this.result.replaceChildren(
      h(
        "div",
        {},
        h(
          "h4",
          {},
          "Set ",
          h("span", { class: "mono", "data-testid": "upload-set-id" }, set.id),
          ` — ${set.files.length} files`,
          set.active ? " (active)" : "",
        ),
        h("div", { class: `state ${cls}`, "data-testid": "upload-valid" }, `validation: ${verdict}`),
        v.errors.length ? problemList(v) : null,
        v.warnings.length
          ? h("ul", { class: "ops-issues" }, ...v.warnings.map((w) => h("li", { class: "warn" }, w)))
          : null,
        !review && schedule && schedule.slots
          ? renderSlotTable(buildSlotTable(schedule), { testid: "upload-schedule" })
          : null,
        h(
          "details",
          {},
          h("summary", {}, "files"),
          h(
            "table",
            { class: "ops-grid ops-dense" },
            h(
              "thead",
              {},
              h(
                "tr",
                {},
                h("th", {}, "path"),
                h("th", {}, "kind"),
                h("th", { class: "num" }, "size"),
                h("th", {}, "sha256"),
              ),
            ),
            h(
              "tbody",
              {},
              ...set.files.map((f) =>
                h(
                  "tr",
                  {},
                  h("td", { class: "mono" }, f.path),
                  h("td", {}, f.kind),
                  h("td", { class: "num" }, formatBytes(f.size)),
                  h("td", { class: "mono ops-sub" }, f.sha256.slice(0, 16)),
                ),
              ),
            ),
          ),
        ),
        review,
      ),
    );
  }
}
