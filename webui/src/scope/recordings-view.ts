// recordings-view.ts -- the Scope page's recordings (GET /recordings, polled): recordings and
// capture shots alike (docs/recorder.md), with state, size, rows and drops, their MCAP download
// (each part on its own when there are several) and the CSV and Parquet exports; operators stop a
// running recording, delete one, and start a recording of the variables chosen in the form.
import type { components } from "../api/schema";
import { h, setText } from "../ops/dom";
import { formatBytes, formatTime } from "../ops/units";

type S = components["schemas"];
export type RecordingPublic = S["RecordingPublic"];
export type RecordingList = S["RecordingList"];
export type RecordingStart = S["RecordingStart"];

const enc = encodeURIComponent;

/** Where a recording's MCAP file(s) and exports are downloaded from (api/routes/recordings.py). */
export function recordingLinks(r: RecordingPublic): { label: string; href: string; testid: string }[] {
  const base = `/api/v1/recordings/${enc(r.name)}`;
  const links = [{ label: r.parts.length > 1 ? "MCAP (zip)" : "MCAP", href: r.download, testid: `download-${r.name}` }];
  if (r.parts.length > 1)
    for (let i = 1; i <= r.parts.length; i++)
      links.push({ label: `part ${i}`, href: `${base}/download?part=${i}`, testid: `download-${r.name}-${i}` });
  links.push({ label: "CSV", href: `${base}/export?format=csv`, testid: `csv-${r.name}` });
  links.push({ label: "Parquet", href: `${base}/export?format=parquet`, testid: `parquet-${r.name}` });
  return links;
}

/** Its kind in words: a recording, or which capture's shot. */
export function kindText(r: RecordingPublic): string {
  if (r.kind !== "capture") return "recording";
  return r.shot ? `capture ${r.shot.capture} shot #${r.shot.shot} (trigger seq ${r.shot.trigger_seq})` : "capture shot";
}

export type StopKind = "manual" | "duration" | "size";

/** The start request from the form's text, or what to fix. */
export function startRequest(
  name: string,
  variables: readonly string[],
  decimation: string,
  stop: StopKind,
  value: string,
): { ok: true; body: RecordingStart } | { ok: false; error: string } {
  if (!name.trim()) return { ok: false, error: "give the recording a name" };
  if (!variables.length)
    return { ok: false, error: "choose the variables to record in the capture form (+ in the tree)" };
  const dec = Number(decimation);
  if (!Number.isInteger(dec) || dec < 1)
    return { ok: false, error: `decimation must be a whole number ≥ 1 (it is ${decimation})` };
  const v = Number(value);
  if (stop !== "manual" && !(Number.isFinite(v) && v > 0))
    return { ok: false, error: `the ${stop === "duration" ? "duration" : "size"} must be a number above 0` };
  const body: RecordingStart = {
    name: name.trim(),
    variables: [...variables],
    decimation: dec,
    stop: stop === "duration" ? { duration_s: v } : stop === "size" ? { max_bytes: Math.round(v * 1e6) } : {},
  };
  return { ok: true, body };
}

export interface RecordingsEnv {
  operator: boolean;
  stop(name: string): void;
  remove(name: string): void;
}

export class RecordingsView {
  readonly el: HTMLElement;
  private body: HTMLElement;
  private info: HTMLElement;
  private sig = "";

  constructor(private env: RecordingsEnv) {
    this.body = h("tbody", {});
    this.info = h("div", { class: "ops-sub", "data-testid": "recordings-use" });
    this.el = h(
      "div",
      {},
      this.info,
      h(
        "div",
        { class: "ops-scroll" },
        h(
          "table",
          { class: "ops-grid ops-dense", "data-testid": "recording-list" },
          h(
            "thead",
            {},
            h(
              "tr",
              {},
              ["name", "kind", "state", "rows", "drops", "size", "created", "download"].map((t) => h("th", {}, t)),
              env.operator ? h("th", {}, "") : null,
            ),
          ),
          this.body,
        ),
      ),
    );
  }

  show(list: RecordingList): void {
    const ch = list.channels;
    setText(
      this.info,
      `${formatBytes(list.used_bytes)} of ${formatBytes(list.quota_bytes)} used (the oldest go first beyond it) · ` +
        `${formatBytes(list.disk_free_bytes)} free on the disk` +
        (ch
          ? ` · trace channels: ${ch.traced} of ${ch.limit} (${Object.entries(ch.owners)
              .map(([k, v]) => `${k} ${v}`)
              .join(", ")})`
          : ""),
    );
    // built again only when something shown changed (never a link replaced under the pointer for nothing)
    const rows = [...list.recordings].reverse(); // newest first
    const sig = JSON.stringify(rows.map((r) => [r.name, r.state, r.rows, r.drops, r.size, r.parts.length]));
    if (sig === this.sig) return;
    this.sig = sig;
    this.body.replaceChildren(
      ...(rows.length
        ? rows.map((r) => this.row(r))
        : [h("tr", {}, h("td", { colspan: 9, class: "muted" }, "nothing recorded yet"))]),
    );
  }

  private row(r: RecordingPublic): HTMLElement {
    const running = r.kind === "recording" && r.state === "recording";
    const actions = h("span", { class: "ops-row-actions" });
    if (this.env.operator) {
      if (running) {
        const stop = h("button", { class: "small", "data-testid": `rec-stop-${r.name}` }, "Stop");
        stop.addEventListener("click", () => this.env.stop(r.name));
        actions.append(stop);
      } else if (r.state !== "recording") {
        // (a shot being written is neither stopped nor deleted: it is done within moments)
        const del = h("button", { class: "small danger", "data-testid": `rec-delete-${r.name}` }, "Delete");
        del.addEventListener("click", () => this.env.remove(r.name));
        actions.append(del);
      }
    }
    const level = r.state === "failed" || r.state === "damaged" ? "bad" : running ? "warn" : "";
    return h(
      "tr",
      { "data-testid": `rec-${r.name}`, "data-kind": r.kind, "data-state": r.state },
      h("td", { class: "mono nowrap" }, r.name),
      h("td", { class: "wrap" }, kindText(r)),
      h("td", { class: `state ${level}`, title: r.reason ?? "" }, r.state, r.cause ? ` (${r.cause})` : ""),
      h("td", { class: "num" }, r.rows),
      h("td", { class: `num ${r.drops ? "bad" : ""}` }, r.drops),
      h("td", { class: "num nowrap" }, formatBytes(r.size)),
      h("td", { class: "nowrap", title: r.created }, r.created ? formatTime(r.created) : "–"),
      h(
        "td",
        { class: "nowrap" },
        r.parts.length
          ? recordingLinks(r).flatMap((l, i) => [
              i ? " · " : "",
              h("a", { href: l.href, download: "", "data-testid": l.testid }, l.label),
            ])
          : "–",
      ),
      this.env.operator ? h("td", { class: "nowrap" }, actions) : null,
    );
  }
}
