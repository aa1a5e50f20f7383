// system.test.ts -- the System page's pieces: the NDJSON stream cut into lines whatever the chunks,
// the followed lines bounded, a log query from the form, a restore's plan and a prune's report in
// words, the certificate's expiry, waiting for a restarted agent; and the page in a DOM: an admin's
// figures, a restart asked for before it is sent, the prune's dry run before the deletion, and a
// viewer shown nothing to act on.
import { describe, expect, it } from "vitest";
import type { AppContext, Role } from "../../src/app/context";
import type { Probe } from "../../src/ops/health";
import {
  appendLines,
  expiryText,
  logQuery,
  NdjsonSplitter,
  type PruneReport,
  planRows,
  pruneText,
  type RestorePlan,
  type SystemInfo,
  waitForAgent,
} from "../../src/ops/system";
import { systemPage } from "../../src/pages/system";
import { fakeApi, flush, q } from "./page-helpers";

describe("the log stream", () => {
  it("is cut into objects whatever the chunks' boundaries", () => {
    const s = new NdjsonSplitter();
    expect(s.push('{"message": "a"}\n{"mess')).toEqual([{ message: "a" }]);
    expect(s.push('age": "b"}\n\nnot json\n{"message"')).toEqual([{ message: "b" }]);
    expect(s.push(': "c"}\n')).toEqual([{ message: "c" }]);
  });

  it("keeps the newest lines only", () => {
    expect(appendLines([1, 2, 3], [4, 5], 4)).toEqual([2, 3, 4, 5]);
    expect(appendLines([1], [2], 4)).toEqual([1, 2]);
  });

  it("asks with the form's fields, the time as UTC", () => {
    expect(logQuery(200, "  ", "")).toEqual({ lines: 200 });
    const q = logQuery(50, " overrun ", "2026-01-31T08:00");
    expect(q.grep).toBe("overrun");
    expect(q.since).toBe(new Date("2026-01-31T08:00").toISOString());
  });
});

const plan: RestorePlan = {
  dry_run: true,
  restarting: false,
  archive: {
    created: "2026-01-31T08:00:00Z",
    agent_version: "0.1.0",
    host: "cell7",
    with_secrets: false,
    files: 12,
    bytes: 2048,
  },
  sets: { added: ["a", "b"], present: ["c"], kept: [] },
  active_set: { now: null, after: "a" },
  tokens: { now: 3, after: 3 },
  users: { now: null, after: 2 },
  audit_lines: { now: 10, after: 40 },
  files: [{ path: "tokens.json", action: "replace", what: "the tokens" }],
  warnings: [],
};

describe("what the page says", () => {
  it("reads a restore's plan as before and after", () => {
    const rows = Object.fromEntries(planRows(plan));
    expect(rows.sets).toBe("2 added, 1 already here, 0 only here (kept)");
    expect(rows["active set"]).toBe("none → a");
    expect(rows.tokens).toBe("3 (unchanged)");
    expect(rows.backup).toContain("cell7");
  });

  it("reads a prune's report", () => {
    const r: PruneReport = {
      dry_run: true,
      deleted: [{ id: "x", created: "2026-01-31T08:00:00Z", by: null, files: 3 }],
      kept: ["a", "b"],
      blobs: [{ sha256: "0".repeat(64), size: 2048 }],
      bytes: 2048,
    };
    expect(pruneText(r)).toBe("would delete 1 set(s) and 1 stored file(s), 2.0 KiB; 2 set(s) kept");
    expect(pruneText({ ...r, dry_run: false })).toMatch(/^deleted /);
  });

  it("warns of a certificate near its end", () => {
    const c = { path: "/c.pem", names: [], not_after: "2027-01-01T00:00:00Z" };
    expect(expiryText({ ...c, days_left: 400 }).level).toBe("good");
    expect(expiryText({ ...c, days_left: 10 })).toEqual({ text: "until 2027-01-01 (10 days)", level: "warn" });
    expect(expiryText({ ...c, days_left: -1 }).level).toBe("bad");
  });
});

describe("waiting for a restarted agent", () => {
  const up: Probe = { ok: true, status: 200, body: { agent: "ok", irpd: "ok", version: "0.1.0" } };
  const down: Probe = { ok: false, error: "connection failed" };
  const noSleep = async () => {};

  it("waits until the agent went away and answers again", async () => {
    const answers = [up, down, down, up];
    let asked = 0;
    const back = await waitForAgent(
      async () => answers[Math.min(asked++, answers.length - 1)],
      10_000,
      500,
      3000,
      noSleep,
    );
    expect(back).toBe(true);
    expect(asked).toBe(4);
  });

  it("gives up after its time", async () => {
    expect(await waitForAgent(async () => down, 2000, 500, 3000, noSleep)).toBe(false);
  });
});

// ---- the page in a DOM ---------------------------------------------------------------------------
const info: SystemInfo = {
  agent: {
    version: "0.1.0",
    pid: 42,
    started: "2026-01-31T08:00:00Z",
    uptime_s: 3725,
    python: "3.11.2",
    supervisor: "systemd",
    scheme: "https",
    host: "0.0.0.0",
    port: 8443,
  },
  irpd: {
    reachable: true,
    version: "0.1.0",
    protocol: 2,
    pid: 7,
    uptime_s: 60,
    set_id: "5c1e0a9b7d3f2e41",
    running: true,
  },
  data: {
    path: "/var/lib/indurop",
    used_bytes: 5 << 20,
    parts: [{ name: "blobs", bytes: 4 << 20 }],
    complete: true,
    filesystem_bytes: 1 << 30,
    free_bytes: 512 << 20,
  },
  tls: {
    path: "/var/lib/indurop/tls/cert.pem",
    fingerprint_sha256: "AB:CD",
    subject: "CN=cell7",
    self_signed: true,
    names: ["cell7", "127.0.0.1"],
    not_after: "2036-01-31T08:00:00Z",
    days_left: 3650,
  },
  logs: { irpd: "journal, unit irpd.service", agent: "journal, unit indurop-agent.service" },
  restore_pending: false,
};

function mount(role: Role) {
  const { calls, api } = fakeApi((path, opts) => {
    if (path === "/api/v1/system") return info;
    if (path === "/api/v1/sets/prune")
      return {
        dry_run: (opts.body as { dry_run: boolean }).dry_run,
        deleted: [],
        kept: ["a"],
        blobs: [{ sha256: "0", size: 10 }],
        bytes: 10,
      };
    if (path === "/api/v1/system/restart/irpd") return { mode: "restart", set_id: "s", pid: 7, downtime_ns: 120e6 };
    return {};
  });
  const ctx = {
    api,
    session: { token: "t", name: "ana", role },
    can: (r: Role) => ({ viewer: 0, operator: 1, admin: 2 })[role] >= { viewer: 0, operator: 1, admin: 2 }[r],
    notify: () => {},
  } as unknown as AppContext;
  const root = document.createElement("div");
  const unmount = systemPage(root, ctx);
  return { root, calls, unmount };
}

describe("the System page", () => {
  it("shows an admin the versions, the data folder and the certificate", async () => {
    const { root, unmount } = mount("admin");
    await flush();
    expect(q(root, "agent-version")?.textContent).toContain("0.1.0 · pid 42 · up 01:02:05");
    expect(q(root, "irpd-version")?.textContent).toContain("set 5c1e0a9b7d3f2e41");
    expect(q(root, "data-used")?.textContent).toContain("5.0 MiB used");
    expect(q(root, "tls-fingerprint")?.textContent).toBe("AB:CD");
    expect(q(root, "tls-expiry")?.textContent).toContain("3650 days");
    unmount();
  });

  it("asks before it restarts irpd, and sends nothing on Cancel", async () => {
    const { root, calls, unmount } = mount("admin");
    await flush();
    q(root, "restart-irpd")!.click();
    expect(q(root, "restart-confirm")!.hidden).toBe(false);
    q(root, "restart-confirm-no")!.click();
    expect(calls.some((c) => c.path.includes("restart"))).toBe(false);
    q(root, "restart-irpd")!.click();
    q(root, "restart-confirm-yes")!.click();
    await flush();
    expect(calls.filter((c) => c.method === "POST").map((c) => c.path)).toEqual(["/api/v1/system/restart/irpd"]);
    expect(q(root, "restart-result")?.textContent).toContain("downtime 120.0 ms");
    unmount();
  });

  it("prunes only after its dry run was confirmed", async () => {
    const { root, calls, unmount } = mount("admin");
    await flush();
    (q(root, "prune-keep") as HTMLInputElement).value = "3";
    q(root, "prune-dry-run")!.click();
    await flush();
    const prunes = () => calls.filter((c) => c.path === "/api/v1/sets/prune").map((c) => c.opts.body);
    expect(prunes()).toEqual([{ keep_last: 3, dry_run: true }]);
    expect(q(root, "prune-report")?.textContent).toContain("would delete 0 set(s) and 1 stored file(s)");
    q(root, "prune-confirm-yes")!.click();
    await flush();
    expect(prunes()).toEqual([
      { keep_last: 3, dry_run: true },
      { keep_last: 3, dry_run: false },
    ]);
    unmount();
  });

  it("shows a viewer nothing to act on", async () => {
    const { root, calls } = mount("viewer");
    await flush();
    expect(root.textContent).toContain("needs the admin role");
    expect(root.querySelector("button")).toBeNull();
    expect(calls).toEqual([]);
  });
});
