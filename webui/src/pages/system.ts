// system.ts -- the System page (admin; docs/administration.md): versions, uptimes, disk use and
// the TLS certificate (GET /system); restarts of irpd and of the agent, each confirmed; irpd's and
// the agent's logs, searched and followed live; the backup download and the restore with its
// dry-run review before it is confirmed; the set store's prune with a dry run; the upload of an
// own TLS certificate.
import "../ops/ops.css";
import { unwrap } from "../api/client";
import type { Page } from "../app/context";
import { errorText, h, poll, setClass, setText } from "../ops/dom";
import {
  appendLines,
  expiryText,
  type LogLine,
  logQuery,
  NdjsonSplitter,
  type PruneReport,
  planRows,
  pruneText,
  type RestorePlan,
  type SystemInfo,
  waitForAgent,
} from "../ops/system";
import { formatBytes, formatTime, formatUptime } from "../ops/units";

const REFRESH_MS = 5000;

/** A confirmation bar: a question, then Confirm / Cancel; `act` runs on Confirm. */
function confirmBar(testid: string) {
  const bar = h("div", { class: "ops-confirm", "data-testid": testid, hidden: true });
  return {
    bar,
    ask(question: string, label: string, act: () => Promise<void>) {
      const yes = h("button", { class: "primary danger", "data-testid": `${testid}-yes` }, label);
      const no = h("button", { "data-testid": `${testid}-no` }, "Cancel");
      bar.replaceChildren(h("span", {}, question, " "), yes, " ", no);
      bar.hidden = false;
      no.addEventListener("click", () => {
        bar.hidden = true;
      });
      yes.addEventListener("click", async () => {
        yes.disabled = true;
        no.disabled = true;
        try {
          await act();
        } finally {
          bar.hidden = true;
        }
      });
    },
    hide() {
      bar.hidden = true;
    },
  };
}

function kvRow(label: string, testid: string): [HTMLElement, HTMLElement] {
  const value = h("td", { "data-testid": testid }, "–");
  return [h("tr", {}, h("th", {}, label), value), value];
}

export const systemPage: Page = (root, ctx) => {
  if (!ctx.can("admin")) {
    root.append(
      h(
        "div",
        { class: "ops-page", "data-testid": "system-page" },
        h(
          "section",
          { class: "panel ops-panel" },
          h("h3", {}, "System"),
          h("p", {}, "The System page needs the admin role."),
        ),
      ),
    );
    return () => {};
  }
  const cleanups: (() => void)[] = [];

  // ---- the figures and the restarts ------------------------------------------------------------
  const rows = {
    agent: kvRow("agent", "agent-version"),
    irpd: kvRow("irpd", "irpd-version"),
    data: kvRow("data folder", "data-used"),
    tls: kvRow("TLS certificate", "tls-subject"),
    fingerprint: kvRow("SHA-256 fingerprint", "tls-fingerprint"),
    expiry: kvRow("valid", "tls-expiry"),
    logs: kvRow("logs from", "log-sources"),
  };
  const infoError = h("div", { class: "ops-error", "data-testid": "system-error", hidden: true, role: "alert" });
  const restartResult = h("div", { class: "ops-sub", "data-testid": "restart-result" });
  const restartConfirm = confirmBar("restart-confirm");
  const restartIrpd = h("button", { "data-testid": "restart-irpd" }, "Restart irpd…");
  const restartAgent = h("button", { "data-testid": "restart-agent" }, "Restart the agent…");
  const figures = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "System"),
    h("table", { class: "ops-kv" }, ...Object.values(rows).map(([tr]) => tr)),
    infoError,
    h("div", { class: "ops-actions" }, restartIrpd, restartAgent),
    restartConfirm.bar,
    restartResult,
  );

  const show = (s: SystemInfo) => {
    const a = s.agent;
    setText(
      rows.agent[1],
      `${a.version} · pid ${a.pid} · up ${formatUptime(a.uptime_s)} · ${a.scheme}://${a.host}:${a.port}` +
        (a.supervisor ? ` · restarted by ${a.supervisor}` : " · no supervisor: restart it by hand"),
    );
    const i = s.irpd;
    setText(
      rows.irpd[1],
      i.reachable
        ? `${i.version ?? "?"} · pid ${i.pid} · up ${formatUptime(i.uptime_s)} · set ${i.set_id ?? "–"}`
        : `unreachable: ${i.detail ?? ""}`,
    );
    setClass(rows.irpd[1], i.reachable ? "" : "bad");
    const d = s.data;
    setText(
      rows.data[1],
      `${d.path}: ${formatBytes(d.used_bytes)} used · ${formatBytes(d.free_bytes)} free of ${formatBytes(d.filesystem_bytes)}` +
        (d.parts.length
          ? ` (${d.parts
              .slice(0, 4)
              .map((p) => `${p.name} ${formatBytes(p.bytes)}`)
              .join(", ")})`
          : ""),
    );
    const t = s.tls;
    if (!t) {
      setText(rows.tls[1], "none: the agent serves plain HTTP");
      setText(rows.fingerprint[1], "–");
      setText(rows.expiry[1], "–");
    } else if (t.error) {
      setText(rows.tls[1], t.error);
      setClass(rows.tls[1], "bad");
    } else {
      setText(
        rows.tls[1],
        `${t.subject ?? ""}${t.self_signed ? " (self-signed)" : ""} · ${(t.names ?? []).join(", ")}`,
      );
      setText(rows.fingerprint[1], t.fingerprint_sha256 ?? "–");
      const e = expiryText(t);
      setText(rows.expiry[1], e.text);
      setClass(rows.expiry[1], e.level === "good" ? "" : e.level);
    }
    setText(rows.logs[1], `irpd: ${s.logs.irpd ?? "none"} · agent: ${s.logs.agent ?? "none"}`);
    restartAgent.disabled = !a.supervisor;
    restartAgent.title = a.supervisor ? "" : "the agent runs without a supervisor that would start it again";
  };
  const refresh = poll(
    async () => {
      show(unwrap(await ctx.api.GET("/api/v1/system")));
      infoError.hidden = true;
    },
    REFRESH_MS,
    (e) => {
      infoError.hidden = false;
      setText(infoError, errorText(e));
    },
  );
  cleanups.push(() => refresh.stop());

  /** After the agent was told to restart (itself, a restore, a certificate): wait, then reload. */
  const awaitAgent = async (why: string) => {
    setText(restartResult, `${why}: waiting for the agent to answer again…`);
    const back = await waitForAgent();
    setText(restartResult, back ? `${why}: the agent is back` : `${why}: the agent did not answer within a minute`);
    if (back) location.reload(); // a new agent: new sessions of the stream and the alarm feed
  };

  restartIrpd.addEventListener("click", () =>
    restartConfirm.ask(
      "Restart irpd onto the active set? Its outputs go to safe values, the cell stops for the restart's downtime.",
      "Restart irpd",
      async () => {
        setText(restartResult, "irpd restarts…");
        try {
          const r = unwrap(await ctx.api.POST("/api/v1/system/restart/irpd"));
          setText(
            restartResult,
            `irpd restarted onto set ${r.set_id ?? "–"} (pid ${r.pid}, downtime ${((r.downtime_ns ?? 0) / 1e6).toFixed(1)} ms)`,
          );
          ctx.notify("irpd restarted");
          refresh.now();
        } catch (e) {
          setText(restartResult, `restart of irpd: ${errorText(e)}`);
          ctx.notify(errorText(e), "error");
        }
      },
    ),
  );
  restartAgent.addEventListener("click", () =>
    restartConfirm.ask(
      "Restart the agent? The API and this page are gone for a few seconds; irpd keeps running.",
      "Restart the agent",
      async () => {
        try {
          unwrap(await ctx.api.POST("/api/v1/system/restart/agent"));
          await awaitAgent("the agent restarts");
        } catch (e) {
          setText(restartResult, `restart of the agent: ${errorText(e)}`);
        }
      },
    ),
  );

  // ---- logs ------------------------------------------------------------------------------------
  const logSelect = h(
    "select",
    { "data-testid": "log-select" },
    h("option", { value: "irpd" }, "irpd"),
    h("option", { value: "agent" }, "agent"),
  );
  const grep = h("input", { type: "search", placeholder: "search", class: "ops-edit", "data-testid": "log-grep" });
  const lines = h("input", {
    type: "number",
    min: 1,
    max: 5000,
    value: 200,
    class: "ops-edit",
    size: 5,
    "data-testid": "log-lines",
  });
  const since = h("input", { type: "datetime-local", class: "ops-edit", "data-testid": "log-since" });
  const showLogs = h("button", { class: "primary", "data-testid": "log-show" }, "Show");
  const follow = h("button", { "data-testid": "log-follow" }, "Follow live");
  const logInfo = h("span", { class: "ops-sub", "data-testid": "log-info" });
  const logError = h("div", { class: "ops-error", "data-testid": "log-error", hidden: true, role: "alert" });
  const logView = h("div", { class: "ops-scroll mono ops-log", "data-testid": "log-lines-view" });
  let shown: LogLine[] = [];
  let following: AbortController | null = null;

  const renderLines = () => {
    const atEnd = logView.scrollTop + logView.clientHeight >= logView.scrollHeight - 4;
    logView.replaceChildren(
      ...shown.map((l) =>
        h(
          "div",
          { class: `ops-log-line${l.priority !== null && l.priority !== undefined && l.priority <= 3 ? " bad" : ""}` },
          h("span", { class: "ops-sub" }, l.time ? formatTime(l.time) : "", " "),
          l.message,
        ),
      ),
    );
    if (atEnd) logView.scrollTop = logView.scrollHeight;
  };
  const query = () => logQuery(Number(lines.value) || 200, grep.value, since.value);
  const stopFollowing = () => {
    following?.abort();
    following = null;
    setText(follow, "Follow live");
  };
  showLogs.addEventListener("click", async () => {
    stopFollowing();
    logError.hidden = true;
    try {
      const log = logSelect.value as "irpd" | "agent";
      const page = unwrap(
        await ctx.api.GET("/api/v1/system/logs/{log}", { params: { path: { log }, query: query() } }),
      );
      shown = page.lines;
      setText(
        logInfo,
        ` — ${page.source}, ${page.lines.length} line(s)${page.truncated ? ", older lines not searched" : ""}`,
      );
      renderLines();
      logView.scrollTop = logView.scrollHeight;
    } catch (e) {
      logError.hidden = false;
      setText(logError, errorText(e));
    }
  });
  follow.addEventListener("click", async () => {
    if (following) {
      stopFollowing();
      return;
    }
    logError.hidden = true;
    const ctl = new AbortController();
    following = ctl;
    setText(follow, "Stop");
    shown = [];
    renderLines();
    const log = logSelect.value as "irpd" | "agent";
    setText(logInfo, ` — following ${log}`);
    try {
      const r = await ctx.api.GET("/api/v1/system/logs/{log}/follow", {
        params: { path: { log }, query: query() },
        parseAs: "stream",
        signal: ctl.signal,
      });
      if (!r.response.ok || !r.data) unwrap(r);
      const reader = (r.data as unknown as ReadableStream<Uint8Array>).getReader();
      const decoder = new TextDecoder();
      const split = new NdjsonSplitter();
      for (;;) {
        const { done, value } = await reader.read();
        if (done) break;
        shown = appendLines(shown, split.push(decoder.decode(value, { stream: true })) as LogLine[]);
        renderLines();
      }
    } catch (e) {
      if (!ctl.signal.aborted) {
        logError.hidden = false;
        setText(logError, errorText(e));
      }
    } finally {
      if (following === ctl) stopFollowing();
    }
  });
  cleanups.push(stopFollowing);
  const logsPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Logs", logInfo),
    h(
      "div",
      { class: "ops-actions" },
      logSelect,
      grep,
      h("label", {}, "lines ", lines),
      h("label", {}, "since ", since),
      showLogs,
      follow,
    ),
    logError,
    logView,
  );

  // ---- backup and restore ----------------------------------------------------------------------
  const withSecrets = h("input", { type: "checkbox", "data-testid": "backup-secrets" });
  const download = h("button", { class: "primary", "data-testid": "backup-download" }, "Download a backup");
  const restoreFile = h("input", {
    type: "file",
    accept: ".tar.gz,.tgz,application/gzip",
    "data-testid": "restore-file",
  });
  const checkRestore = h("button", { "data-testid": "restore-check", disabled: true }, "Check it…");
  const backupError = h("div", { class: "ops-error", "data-testid": "backup-error", hidden: true, role: "alert" });
  const planView = h("div", { "data-testid": "restore-plan", hidden: true });
  const restoreConfirm = confirmBar("restore-confirm");

  download.addEventListener("click", async () => {
    backupError.hidden = true;
    download.disabled = true;
    try {
      const r = await ctx.api.GET("/api/v1/system/backup", {
        params: { query: { with_secrets: withSecrets.checked } },
        parseAs: "blob",
      });
      const blob = unwrap(r) as unknown as Blob;
      const named = /filename="?([^";]+)"?/.exec(r.response.headers.get("content-disposition") ?? "");
      const a = h("a", { href: URL.createObjectURL(blob), download: named?.[1] ?? "indurop-backup.tar.gz" });
      a.click();
      setTimeout(() => URL.revokeObjectURL(a.href), 60_000);
      ctx.notify(`backup downloaded (${formatBytes(blob.size)})`);
    } catch (e) {
      backupError.hidden = false;
      setText(backupError, `backup: ${errorText(e)}`);
    } finally {
      download.disabled = false;
    }
  });
  const sendRestore = async (dryRun: boolean): Promise<RestorePlan> => {
    const file = restoreFile.files?.[0];
    if (!file) throw new Error("choose a backup file first");
    return unwrap(
      await ctx.api.POST("/api/v1/system/restore", {
        params: { query: { dry_run: dryRun } },
        body: file as unknown as string,
        bodySerializer: (b: unknown) => b as Blob,
        headers: { "Content-Type": "application/gzip" },
      }),
    );
  };
  const showPlan = (p: RestorePlan) => {
    planView.hidden = false;
    planView.replaceChildren(
      h("table", { class: "ops-kv" }, ...planRows(p).map(([k, v]) => h("tr", {}, h("th", {}, k), h("td", {}, v)))),
      p.files.length
        ? h(
            "table",
            { class: "ops-grid ops-dense", "data-testid": "restore-files" },
            h("thead", {}, h("tr", {}, h("th", {}, "file"), h("th", {}, "action"), h("th", {}, "what"))),
            h(
              "tbody",
              {},
              ...p.files.map((f) =>
                h("tr", {}, h("td", { class: "mono" }, f.path), h("td", {}, f.action), h("td", {}, f.what)),
              ),
            ),
          )
        : "",
      ...p.warnings.map((w) => h("div", { class: "warn", "data-testid": "restore-warning" }, `⚠ ${w}`)),
    );
  };
  restoreFile.addEventListener("change", () => {
    checkRestore.disabled = !restoreFile.files?.length;
    planView.hidden = true;
    restoreConfirm.hide();
  });
  checkRestore.addEventListener("click", async () => {
    backupError.hidden = true;
    planView.hidden = true;
    checkRestore.disabled = true;
    try {
      const plan = await sendRestore(true);
      showPlan(plan);
      restoreConfirm.ask(
        "Restore this backup? The files above are replaced (the current ones are kept aside) and the agent restarts.",
        "Restore",
        async () => {
          try {
            const done = await sendRestore(false);
            showPlan(done);
            if (done.restarting) await awaitAgent("the backup is restored");
            else setText(restartResult, "the backup is staged: it is applied when the agent starts again");
          } catch (e) {
            backupError.hidden = false;
            setText(backupError, `restore: ${errorText(e)}`);
          }
        },
      );
    } catch (e) {
      backupError.hidden = false;
      setText(backupError, `the backup was refused: ${errorText(e)}`);
    } finally {
      checkRestore.disabled = !restoreFile.files?.length;
    }
  });
  const backupPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Backup and restore"),
    h(
      "div",
      { class: "ops-actions" },
      download,
      h("label", {}, withSecrets, " with secrets (users' password hashes, the TLS key)"),
    ),
    h("div", { class: "ops-actions" }, "Restore: ", restoreFile, checkRestore),
    backupError,
    planView,
    restoreConfirm.bar,
  );

  // ---- the set store's prune -------------------------------------------------------------------
  const keep = h("input", {
    type: "number",
    min: 0,
    value: 10,
    class: "ops-edit",
    size: 4,
    "data-testid": "prune-keep",
  });
  const dryRun = h("button", { "data-testid": "prune-dry-run" }, "Dry run");
  const pruneError = h("div", { class: "ops-error", "data-testid": "prune-error", hidden: true, role: "alert" });
  const pruneReport = h("div", { "data-testid": "prune-report" });
  const pruneConfirm = confirmBar("prune-confirm");
  const prune = async (dry: boolean): Promise<PruneReport> =>
    unwrap(await ctx.api.POST("/api/v1/sets/prune", { body: { keep_last: Number(keep.value), dry_run: dry } }));
  const showPrune = (r: PruneReport) =>
    pruneReport.replaceChildren(
      h("div", {}, pruneText(r)),
      r.deleted.length
        ? h(
            "ul",
            { class: "mono" },
            ...r.deleted.map((s) =>
              h("li", {}, `${s.id} · ${formatTime(s.created)} · ${s.files} files · ${s.by?.name ?? "–"}`),
            ),
          )
        : "",
    );
  dryRun.addEventListener("click", async () => {
    pruneError.hidden = true;
    try {
      const r = await prune(true);
      showPrune(r);
      if (r.deleted.length || r.blobs.length)
        pruneConfirm.ask(`Delete these ${r.deleted.length} set(s) for good?`, "Delete", async () => {
          try {
            showPrune(await prune(false));
            ctx.notify("the set store was pruned");
            refresh.now();
          } catch (e) {
            pruneError.hidden = false;
            setText(pruneError, errorText(e));
          }
        });
    } catch (e) {
      pruneError.hidden = false;
      setText(pruneError, errorText(e));
    }
  });
  const prunePanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "Set store cleanup"),
    h(
      "div",
      { class: "ops-actions" },
      h("label", {}, "keep the newest ", keep, " sets (and the active one, and the rollback target)"),
      dryRun,
    ),
    pruneError,
    pruneReport,
    pruneConfirm.bar,
  );

  // ---- an own TLS certificate ------------------------------------------------------------------
  const certFile = h("input", { type: "file", accept: ".pem,.crt", "data-testid": "tls-cert-file" });
  const keyFile = h("input", { type: "file", accept: ".pem,.key", "data-testid": "tls-key-file" });
  const uploadTls = h("button", { "data-testid": "tls-upload" }, "Install…");
  const tlsError = h("div", { class: "ops-error", "data-testid": "tls-error", hidden: true, role: "alert" });
  const tlsConfirm = confirmBar("tls-confirm");
  uploadTls.addEventListener("click", () => {
    const cert = certFile.files?.[0];
    const key = keyFile.files?.[0];
    tlsError.hidden = true;
    if (!cert || !key) {
      tlsError.hidden = false;
      setText(tlsError, "choose the certificate (PEM) and its key (PEM)");
      return;
    }
    tlsConfirm.ask("Install this certificate? The agent restarts to serve it.", "Install", async () => {
      try {
        const done = unwrap(
          await ctx.api.POST("/api/v1/system/tls", { body: { certificate: await cert.text(), key: await key.text() } }),
        );
        ctx.notify(`certificate ${done.certificate.fingerprint_sha256} installed`);
        if (done.restarting) await awaitAgent("the certificate is installed");
      } catch (e) {
        tlsError.hidden = false;
        setText(tlsError, errorText(e));
      }
    });
  });
  const tlsPanel = h(
    "section",
    { class: "panel ops-panel" },
    h("h3", {}, "TLS certificate"),
    h(
      "div",
      { class: "ops-actions" },
      h("label", {}, "certificate ", certFile),
      h("label", {}, "key ", keyFile),
      uploadTls,
    ),
    tlsError,
    tlsConfirm.bar,
  );

  root.append(
    h(
      "div",
      { class: "ops-page", "data-testid": "system-page" },
      h("div", { class: "ops-cols" }, figures, backupPanel),
      logsPanel,
      h("div", { class: "ops-cols" }, prunePanel, tlsPanel),
    ),
  );
  return () => {
    for (const c of cleanups) c();
  };
};
