// scope-page.test.ts -- the Scope page in a DOM against answers given here: the tree's + fills the
// form and Arm sends the request it makes; the agent's refusal is shown next to the form; a shot is
// plotted with its trigger seq and pre/post counts; a configuration is saved with the active set
// (PUT) and restored into the form; a viewer sees the captures, the shots and the downloads but no
// button that changes anything.
import "./dom-shims";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import type { AppContext, Role } from "../../src/app/context";

const { scopePage } = await import("../../src/pages/scope");

const SET = "1b8018068ba90d06";
const SQUARE = "SIG.wave[4]";
const REQUEST = {
  name: "",
  variables: [SQUARE],
  trigger: {
    kind: "condition",
    combine: "and",
    conditions: [{ kind: "edge", variable: SQUARE, direction: "rising", threshold: 0 }],
  },
  pre: { rows: 200, seconds: null },
  post: { rows: 100, seconds: null },
  repeat: 1,
};
const SUMMARY = {
  shot: 1,
  trigger_seq: 9751,
  first_seq: 9551,
  last_seq: 9851,
  pre_rows: 200,
  post_rows: 100,
  rows: 301,
  drops: 0,
  cause: "condition",
  trigger_time_ns: 0,
  notes: [],
};
const CAPTURE = {
  id: "3631b11105",
  name: "",
  state: "done",
  request: REQUEST,
  channels: [{ path: SQUARE, type: "double" }],
  pre_rows: 200,
  post_rows: 100,
  basic_period_ns: 1_000_000,
  pre_filled: 200,
  shots_taken: 1,
  lost_rows: 0,
  created: "2026-11-26T19:00:00Z",
  armed_at: null,
  by: "otto",
  message: null,
  shots: [SUMMARY],
};
const SHOT_ENTRY = {
  name: "3631b11105.shot-1",
  kind: "capture",
  state: "stopped",
  created: "2026-11-26T19:00:01Z",
  variables: [],
  rows: 301,
  drops: 0,
  gaps: [],
  parts: [{ file: "part-0001.mcap", size: 5000, closed: true }],
  size: 5000,
  duration_s: 0.3,
  first_time: null,
  last_time: null,
  joint_states: [],
  download: "/api/v1/recordings/3631b11105.shot-1/download",
  shot: { capture: "3631b11105", shot: 1, trigger_seq: 9751, cause: "condition" },
};
const TWO = [...CAPTURE.channels, { path: "SIG.sample", type: "uint64_t" }];
const SAVED = {
  name: "square-rising",
  set_id: SET,
  saved: "2026-11-26T19:00:02Z",
  by: { id: null, name: "otto", role: "operator" },
  size: 900,
  config: { capture: REQUEST, plotted: null, mode: "time", xy: null },
  error: null,
};

interface Call {
  method: string;
  path: string;
  opts: { params?: { path?: Record<string, string>; query?: Record<string, unknown> }; body?: unknown };
}

function mount(role: Role, refuse: string | null = null, saved: unknown[] = [SAVED]) {
  const calls: Call[] = [];
  const answers: Record<string, unknown> = {
    "/api/v1/variables": {
      variables: [
        { path: SQUARE, type: "double", size: 8 },
        { path: "SIG.sample", type: "uint64_t", size: 8 },
        { path: "SIG.letter", type: "char", size: 1 },
        { path: "Main.count", type: "int32_t", size: 4, iec_type: "DINT" }, // a Structured Text variable
      ],
    },
    "/api/v1/captures": { captures: [{ ...CAPTURE, channels: TWO }] },
    "/api/v1/captures/limits": {
      max_channels: 64,
      max_conditions: 4,
      max_pre_rows: 16384,
      ring_rows: 16384,
      max_post_rows: 1_000_000,
      max_hold_rows: 1_000_000,
      max_repeat: 100_000,
      max_name_chars: 200,
    },
    "/api/v1/status": { basic_period_ns: 1_000_000 },
    "/api/v1/sets": [{ id: SET, active: true }],
    "/api/v1/sets/{set_id}/scopes": { set_id: SET, scopes: saved, max_configs: 100, max_bytes: 262144 },
    "/api/v1/recordings": {
      recordings: [SHOT_ENTRY],
      quota_bytes: 4 << 30,
      used_bytes: 5000,
      disk_free_bytes: 1 << 30,
      min_free_bytes: 1 << 28,
      channels: null,
    },
    "/api/v1/captures/{capture_id}/shots/{shot}": {
      capture: CAPTURE.id,
      summary: SUMMARY,
      channels: TWO,
      basic_period_ns: 1_000_000,
      seq: Array.from({ length: 301 }, (_, k) => 9551 + k),
      t_ns: Array.from({ length: 301 }, (_, k) => (9551 + k) * 1e6),
      columns: [Array.from({ length: 301 }, (_, k) => (k < 200 ? -1 : 1)), Array.from({ length: 301 }, (_, k) => k)],
      every: 1,
    },
  };
  const answer =
    (method: string) =>
    async (path: string, opts: Call["opts"] = {}) => {
      calls.push({ method, path, opts });
      if (method === "POST" && path === "/api/v1/captures" && refuse)
        return { error: { detail: refuse }, response: new Response(null, { status: 422 }) };
      const data = method === "GET" ? answers[path] : method === "POST" ? CAPTURE : SAVED;
      return { data, response: new Response(null, { status: method === "POST" ? 201 : 200 }) };
    };
  const ctx = {
    api: { GET: answer("GET"), POST: answer("POST"), PUT: answer("PUT"), DELETE: answer("DELETE") },
    session: { name: "x", role, csrf: "c" },
    can: (r: Role) => role === "operator" || r === "viewer",
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  document.body.appendChild(root);
  const unmount = scopePage(root, ctx);
  return { root, calls, unmount };
}

const settle = () => new Promise((r) => setTimeout(r, 30));
const q = <T extends HTMLElement = HTMLElement>(root: HTMLElement, testid: string) =>
  root.querySelector<T>(`[data-testid="${testid}"]`);
const type = (e: HTMLInputElement | HTMLSelectElement, v: string) => {
  e.value = v;
  e.dispatchEvent(new Event(e instanceof HTMLSelectElement ? "change" : "input"));
};

let mounted: { root: HTMLElement; unmount: () => void } | null = null;
beforeEach(() => {
  // the plot's canvases: a 2D context that draws nothing
  vi.spyOn(HTMLCanvasElement.prototype, "getContext").mockImplementation(
    () => new Proxy({}, { get: (_t, k) => (k === "measureText" ? () => ({ width: 10 }) : () => {}) }) as never,
  );
});
afterEach(() => {
  mounted?.unmount();
  mounted?.root.remove();
  mounted = null;
  vi.restoreAllMocks();
});

describe("the Scope page", () => {
  it("arms what the form asks for: the tree's + gives the variable and the trigger's", async () => {
    const m = mount("operator");
    mounted = m;
    await settle();
    q(m.root, `plotvar-${SQUARE}`)!.click();
    expect(q<HTMLInputElement>(m.root, "cond-0-variable")!.value).toBe(SQUARE);
    type(q<HTMLInputElement>(m.root, "pre")!, "200");
    type(q<HTMLInputElement>(m.root, "post")!, "100");
    q(m.root, "arm")!.click();
    await settle();
    const post = m.calls.find((c) => c.method === "POST");
    expect(post?.path).toBe("/api/v1/captures");
    expect(post?.opts.body).toEqual({ ...REQUEST, pre: { rows: 200 }, post: { rows: 100 } });
    expect(q(m.root, "form-error")!.hidden).toBe(true);
    // the capture armed here: its shot is plotted as it comes, at the next look at the captures
    await vi.waitFor(() => expect(q(m.root, "shot-info-0")?.dataset.triggerSeq).toBe("9751"), { timeout: 3000 });
  });

  it("names each variable's type in the picker and on the chips, a Structured Text one's IEC type beside the C++ one", async () => {
    const m = mount("operator");
    mounted = m;
    await settle();
    const offered = (path: string) =>
      m.root.querySelector<HTMLOptionElement>(`#scope-all-paths option[value="${path}"]`)?.label;
    expect([offered("Main.count"), offered("SIG.sample")]).toEqual(["DINT (int32_t)", "uint64_t"]);
    q(m.root, "plotvar-Main.count")!.click(); // the tree's +: a captured variable's chip
    expect(q(m.root, "capvar-Main.count")!.title).toBe("Main.count: DINT (int32_t)");
    q(m.root, `plot-${CAPTURE.id}`)!.click(); // the plot's chips (its legend) name the shot's variables
    await settle();
    expect(q(m.root, `chip-${SQUARE}`)!.title).toBe(`${SQUARE}: double`);
  });

  it("says what to fix before sending, and shows the agent's refusal next to the form", async () => {
    const m = mount("operator", "'SIG.wave[4]' is not a channel irpd can trace now");
    mounted = m;
    await settle();
    q(m.root, "arm")!.click(); // nothing chosen yet: refused here, nothing sent
    expect(q(m.root, "form-error")!.textContent).toContain("choose at least one variable");
    expect(m.calls.some((c) => c.method === "POST")).toBe(false);
    q(m.root, `plotvar-${SQUARE}`)!.click();
    type(q<HTMLInputElement>(m.root, "pre")!, "16385");
    q(m.root, "arm")!.click();
    expect(q(m.root, "form-error")!.textContent).toContain("at most 16384 rows"); // GET /captures/limits' figure
    type(q<HTMLInputElement>(m.root, "pre")!, "10");
    q(m.root, "arm")!.click();
    await settle();
    const error = q(m.root, "form-error")!;
    expect(error.hidden).toBe(false);
    expect(error.textContent).toBe("HTTP 422: 'SIG.wave[4]' is not a channel irpd can trace now");
  });

  it("plots a shot with its trigger seq and pre/post counts, fetched whole", async () => {
    const m = mount("viewer");
    mounted = m;
    await settle();
    q(m.root, `plot-${CAPTURE.id}`)!.click();
    await settle();
    const get = m.calls.find((c) => c.path.endsWith("/shots/{shot}"));
    expect(get?.opts.params).toEqual({ path: { capture_id: CAPTURE.id, shot: 1 }, query: { every: 1 } });
    const info = q(m.root, "shot-info-0")!;
    expect(info.dataset).toMatchObject({ triggerSeq: "9751", pre: "200", post: "100", drops: "0" });
    expect(info.textContent).toContain("trigger seq 9751 · 200 rows before, 100 after");
  });

  it("saves the form with the active set and restores a saved configuration into it", async () => {
    const m = mount("operator");
    mounted = m;
    await settle();
    expect(q(m.root, "saved-set")!.textContent).toContain(SET);
    q(m.root, `restore-${SAVED.name}`)!.click();
    expect(q<HTMLInputElement>(m.root, "cond-0-variable")!.value).toBe(SQUARE);
    expect(q<HTMLSelectElement>(m.root, "cond-0-direction")!.value).toBe("rising");
    expect(q<HTMLInputElement>(m.root, "pre")!.value).toBe("200");
    expect(q<HTMLInputElement>(m.root, "save-name")!.value).toBe(SAVED.name);
    type(q<HTMLInputElement>(m.root, "save-name")!, "again");
    q(m.root, "save-scope")!.click();
    await settle();
    const put = m.calls.find((c) => c.method === "PUT");
    expect(put?.path).toBe("/api/v1/sets/{set_id}/scopes/{name}");
    expect(put?.opts.params?.path).toEqual({ set_id: SET, name: "again" });
    expect(put?.opts.body).toEqual({
      capture: { ...REQUEST, pre: { rows: 200 }, post: { rows: 100 } },
      plotted: null,
      mode: "time",
      xy: null,
    });
  });

  it("plots shots as a restored configuration says: its channels and its x–y mode", async () => {
    const xy = {
      ...SAVED,
      name: "xy",
      config: { ...SAVED.config, plotted: [SQUARE, "SIG.sample"], mode: "xy", xy: ["SIG.sample", SQUARE] },
    };
    const one = { ...SAVED, name: "one", config: { ...SAVED.config, plotted: ["SIG.sample"] } };
    const m = mount("viewer", null, [xy, one]);
    mounted = m;
    await settle();
    const chips = () =>
      [...m.root.querySelectorAll("[data-testid=plot-panel-1] .chip")].map((c) =>
        c.getAttribute("data-testid")!.replace(/^chip-/, ""),
      );
    const mode = () => q<HTMLSelectElement>(m.root, "mode")!.value;
    q(m.root, `plot-${CAPTURE.id}`)!.click();
    await settle();
    expect([chips(), mode()]).toEqual([[SQUARE, "SIG.sample"], "time"]);
    q(m.root, "restore-one")!.click(); // applied to the shot shown, and to those plotted after
    expect([chips(), mode()]).toEqual([["SIG.sample"], "time"]);
    q(m.root, `plot-${CAPTURE.id}`)!.click();
    await settle();
    expect(chips()).toEqual(["SIG.sample"]);
    q(m.root, "restore-xy")!.click();
    expect([chips(), mode()]).toEqual([[SQUARE, "SIG.sample"], "xy"]);
    expect([q<HTMLSelectElement>(m.root, "xy-x")!.value, q<HTMLSelectElement>(m.root, "xy-y")!.value]).toEqual([
      "SIG.sample",
      SQUARE,
    ]);
  });

  it("starts a recording of the form's variables, with a decimation and a stop, after checking them", async () => {
    const m = mount("operator");
    mounted = m;
    await settle();
    q(m.root, "rec-start")!.click();
    expect(q(m.root, "rec-error")!.textContent).toBe("give the recording a name");
    type(q<HTMLInputElement>(m.root, "rec-name")!, "run-7");
    q(m.root, "rec-start")!.click();
    expect(q(m.root, "rec-error")!.textContent).toContain("choose the variables to record");
    q(m.root, `plotvar-${SQUARE}`)!.click();
    type(q<HTMLInputElement>(m.root, "rec-decimation")!, "10");
    type(q<HTMLSelectElement>(m.root, "rec-stop-kind")!, "duration");
    type(q<HTMLInputElement>(m.root, "rec-stop-value")!, "60");
    q(m.root, "rec-start")!.click();
    await settle();
    const post = m.calls.find((c) => c.method === "POST" && c.path === "/api/v1/recordings");
    expect(post?.opts.body).toEqual({ name: "run-7", variables: [SQUARE], decimation: 10, stop: { duration_s: 60 } });
  });

  it("links every part of a recording that has several, and its exports", async () => {
    const { recordingLinks } = await import("../../src/scope/recordings-view");
    const parts = [SHOT_ENTRY.parts[0], SHOT_ENTRY.parts[0]];
    const links = recordingLinks({
      ...SHOT_ENTRY,
      name: "run-7",
      parts,
      download: "/api/v1/recordings/run-7/download",
    } as never);
    expect(links.map((l) => `${l.label} ${l.href}`)).toEqual([
      "MCAP (zip) /api/v1/recordings/run-7/download",
      "part 1 /api/v1/recordings/run-7/download?part=1",
      "part 2 /api/v1/recordings/run-7/download?part=2",
      "CSV /api/v1/recordings/run-7/export?format=csv",
      "Parquet /api/v1/recordings/run-7/export?format=parquet",
    ]);
  });

  it("gives a viewer the captures, the shots and the downloads, and no button that changes anything", async () => {
    const m = mount("viewer");
    mounted = m;
    await settle();
    expect(q(m.root, `capture-${CAPTURE.id}`)).not.toBeNull();
    expect(q(m.root, `plot-${CAPTURE.id}`)).not.toBeNull();
    expect(q(m.root, `restore-${SAVED.name}`)).not.toBeNull();
    for (const id of ["arm", "save-scope", "rec-start", `rearm-${CAPTURE.id}`, `delete-${CAPTURE.id}`])
      expect(q(m.root, id)).toBeNull();
    expect(m.root.querySelector("[data-testid^=arm-saved-], [data-testid^=rec-delete-]")).toBeNull();
    const links = [...m.root.querySelectorAll<HTMLAnchorElement>(`[data-testid="rec-${SHOT_ENTRY.name}"] a`)];
    expect(links.map((a) => a.getAttribute("href"))).toEqual([
      SHOT_ENTRY.download,
      `/api/v1/recordings/${SHOT_ENTRY.name}/export?format=csv`,
      `/api/v1/recordings/${SHOT_ENTRY.name}/export?format=parquet`,
    ]);
    expect(q(m.root, `rec-${SHOT_ENTRY.name}`)!.textContent).toContain("capture 3631b11105 shot #1");
  });
});
